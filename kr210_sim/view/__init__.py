"""The live web viewer: MuJoCo Studio glue and the live cycle loop."""
