"""The check command and run's refusal of a cell no slot of which can be served."""

from __future__ import annotations

from pathlib import Path

import pytest

from kr210_sim.cell.load import compile_cell, model_for
from kr210_sim.cell.toml import PUBLISHED_CELL, parse_cell
from kr210_sim.cli import main
from kr210_sim.errors import UnservableCellError
from kr210_sim.plan.cellcheck import check_cell, first_served_slot
from kr210_sim.sim.runner import RunConfig, Runner

CELLS = PUBLISHED_CELL.parent


def test_the_published_cell_is_served_without_detours() -> None:
    model = model_for()
    result = check_cell(model)
    assert result.ok and len(result.slots) == 9 and len(result.drops) == 9
    assert not any(r.detour for r in (*result.slots, *result.drops))
    # every slot's cycle carries to the drop spot a run's first cycle picks
    runner = Runner(RunConfig(cycles=1), model=model)
    sample, k = runner.start_cycle(1, 5)
    plan = runner.plan_cycle(runner.observe_target(k), sample.spec)
    assert [r.drop_spot for r in result.slots] == [plan.drop_spot + 1] * 9 == [1] * 9
    assert [r.drop_spot for r in result.drops] == list(range(1, 10))


def test_an_unreachable_shelf_is_rejected_with_a_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", "--cell", str(CELLS / "unreachable.toml")]) == 1
    out = capsys.readouterr().out
    assert out.startswith("cell unreachable: NOT SERVED")
    assert out.count("out of reach") == 9 and "slot 9" in out and "drop 9" in out


def test_run_refuses_a_cell_no_slot_of_which_can_be_served(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report = tmp_path / "r.json"
    code = main(["run", "--cell", str(CELLS / "unreachable.toml"), "--report", str(report)])
    assert code == 2 and not report.exists()
    err = capsys.readouterr().err
    assert "cell unreachable: NOT SERVED" in err
    assert err.strip().splitlines()[-1] == (
        "kr210_sim: error: cell unreachable: no slot can be served (see the table above)"
    )


def test_run_plans_slots_only_until_one_is_served() -> None:
    """What ``run`` needs before it starts (it ran the whole check: every slot and drop spot,
    seconds in an obstacle cell): the column cell's slot 1 serves, the unreachable cell none."""
    assert first_served_slot(model_for(cell=CELLS / "column.toml")) == 1
    assert first_served_slot(model_for(cell=CELLS / "unreachable.toml")) == 0


def test_view_refuses_it_too(tmp_path: Path) -> None:
    from kr210_sim.jobs import view_job
    from kr210_sim.view.live import LiveSettings
    from kr210_sim.view.studio import ViewerSettings

    report = tmp_path / "v.json"
    with pytest.raises(UnservableCellError, match="no slot can be served"):
        view_job(
            RunConfig(cycles=1),
            report,
            ViewerSettings(),
            LiveSettings(exit_when_done=True),
            cell=CELLS / "unreachable.toml",
        )
    assert not report.exists()


def test_the_column_cell_needs_detours_and_gets_them() -> None:
    result = check_cell(model_for(cell=CELLS / "column.toml"))
    assert result.ok
    assert sum(r.detour for r in result.slots) >= 5


def test_a_slot_whose_radial_pick_collides_is_served_from_another_heading() -> None:
    """The column moved beside the shelf's left bay (2.0, 0.55): link 4 strikes it at every
    radial pose of slots 1, 4 and 7 (no_path before); they are picked 25-30 deg off the radial,
    and the table says so."""
    text = (CELLS / "column.toml").read_text()
    text = text.replace("position = [1.8, 1.0, 1.5]", "position = [2.0, 0.55, 1.5]")
    result = check_cell(compile_cell(parse_cell(text)))
    assert result.ok
    assert [r.heading_deg for r in result.slots] == [-30, 0, 0, -25, 0, 0, -30, 0, 0]
    assert "picked -25 deg off the radial (that one collides)" in result.table()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["other_side", "grid_4x2", "column", "slalom", "wall"])
def test_example_cells_run_with_no_contact(name: str) -> None:
    """Three cycles per example cell (bottom, middle and top rows); `run --cycles 10` on each
    is 10/10 too (README)."""
    runner = Runner(RunConfig(cycles=3), model=model_for(cell=CELLS / f"{name}.toml"))
    n = runner.layout.n_slots
    columns = {"grid_4x2": 2}.get(name, 3)
    for i, slot in enumerate((1, n // 2 + 1, n - columns + 1), start=1):
        r = runner.run_cycle(i, slot)
        assert r.success, r.detail
        assert r.env_contact_ticks == 0
    detours = sum(r.detours for r in runner.results)
    if name in ("column", "slalom", "wall"):  # OMPL plans around the obstacles
        assert detours >= 2
        assert any(m[1] == "ompl" for r in runner.results for m in r.moves)
    else:
        assert detours == 0


def test_a_drop_spot_whose_cylinder_cannot_reach_the_bin_floor_is_not_served() -> None:
    """A scene with a crate in the bin passed `check` (every cycle then ended missed_bin)."""
    import mujoco

    from kr210_sim.cell.layout import CellLayout
    from kr210_sim.plan.cellcheck import landing_blocker
    from kr210_sim.util.paths import SCENE_PATH

    published = model_for()
    layout = CellLayout.from_model(published)
    assert all(landing_blocker(published, layout, n) == "" for n in range(1, 10))
    spec = mujoco.MjSpec.from_file(str(SCENE_PATH))
    crate = spec.worldbody.add_body(name="crate", pos=[0.0, 2.5, 0.4])
    crate.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.3, 0.3, 0.3])
    blocked = spec.compile()
    for n in range(1, 10):
        why = landing_blocker(blocked, CellLayout.from_model(blocked), n)
        assert why.startswith("a cylinder dropped here lands on crate at z = 0.70 m"), why
