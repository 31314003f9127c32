"""What makes pixels: rendering, video encoding, the render pool, recordings, plots and pictures."""
