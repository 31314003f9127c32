"""Signals and closed pipes, on a real ``python -m kr210_sim run`` process: what finished is kept.

Each test starts the command, waits for its first cycle line (or for a chosen moment of its
start-up), then does to it what a user or a CI runner would (Ctrl-C to the process group,
SIGTERM, two signals a few ms apart, ``| head -1``, a full device).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import imageio.v2 as imageio
import pytest

pytestmark = pytest.mark.slow

COMMAND = [sys.executable, "-m", "kr210_sim", "run"]


def _start(args: list[str], cwd: Path, **kwargs: object) -> subprocess.Popen[str]:
    return subprocess.Popen(  # type: ignore[call-overload, no-any-return]
        [*COMMAND, *args],
        cwd=cwd,
        text=True,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its own process group, as a shell job would be
        **{"stdout": subprocess.PIPE, **kwargs},
    )


def _first_cycle(proc: subprocess.Popen[str]) -> str:
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert line.startswith("[ 1/"), line
    return line


def test_sigterm_writes_the_cycles_done_and_exits_143(tmp_path: Path) -> None:
    report = tmp_path / "run.json"
    proc = _start(["--cycles", "40", "--report", str(report)], tmp_path)
    _first_cycle(proc)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "Traceback" not in err
    assert "interrupted after" in err and "SIGTERM" in err
    data = json.loads(report.read_text())
    assert data["interrupted"] is True and data["interrupted_by"] == "SIGTERM"
    assert 1 <= data["summary"]["cycles"] < 40


@pytest.mark.render
def test_ctrl_c_during_a_video_keeps_a_playable_partial_mp4(tmp_path: Path) -> None:
    report, video = tmp_path / "run.json", tmp_path / "run.mp4"
    args = ["--cycles", "40", "--report", str(report), "--video", str(video)]
    video_args = ["--width", "160", "--height", "128", "--fps", "5", "--quality", "fast"]
    proc = _start([*args, *video_args], tmp_path)
    _first_cycle(proc)
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "video recording failed" not in err
    data = json.loads(report.read_text())
    assert data["interrupted"] is True and data["interrupted_by"] == "SIGINT"
    cycles = data["summary"]["cycles"]
    assert 1 <= cycles < 40
    frames = [f for f in imageio.get_reader(video)]  # list() fails: len() is inf
    # At least the first cycle's frames (5 a simulated second), all decodable.
    assert len(frames) >= 5 * 4 and frames[0].shape == (128, 160, 3)
    assert f"({len(frames)} frames)" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json", "run.mp4"]


def test_a_closed_stdout_does_not_lose_the_report(tmp_path: Path) -> None:
    report = tmp_path / "run.json"
    proc = _start(["--cycles", "12", "--slot", "5", "--report", str(report)], tmp_path)
    _first_cycle(proc)
    assert proc.stdout is not None
    proc.stdout.close()  # `| head -1`
    assert proc.stderr is not None
    err = proc.stderr.read()
    assert proc.wait(timeout=60) == 0, err
    assert err == ""  # a broken pipe is not worth a word
    assert json.loads(report.read_text())["summary"]["cycles"] == 12


def test_stdout_on_a_full_device_does_not_lose_the_report(tmp_path: Path) -> None:
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    report = tmp_path / "run.json"
    with open("/dev/full", "w") as full:
        proc = subprocess.run(
            [*COMMAND, "--cycles", "2", "--slot", "5", "--report", str(report)],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            cwd=tmp_path,
            check=False,
            timeout=120,
        )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.splitlines() == [
        "kr210_sim: warning: stdout cannot be written (No space left on device); its output is "
        "dropped, reports are still written"
    ]
    assert json.loads(report.read_text())["summary"]["cycles"] == 2


def test_deferred_holds_an_interrupt_until_the_step_is_done() -> None:
    from kr210_sim.util.interrupts import Interrupted, deferred, terminate_as_interrupt

    steps: list[str] = []
    with terminate_as_interrupt(), pytest.raises(Interrupted) as caught:
        with deferred():
            os.kill(os.getpid(), signal.SIGTERM)
            steps.append("finished")  # the step runs to its end
        steps.append("after")  # never reached: the held SIGTERM is raised at the block's end
    assert steps == ["finished"] and caught.value.signum == signal.SIGTERM
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a terminal
    try:
        with pytest.raises(KeyboardInterrupt), deferred():
            os.kill(os.getpid(), signal.SIGINT)
            steps.append("again")
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored
    finally:
        signal.signal(signal.SIGINT, previous)
    assert steps[-1] == "again"


def _ik_that_signals(folder: Path, swallow: bool) -> str:
    """An IK module whose import sends this process SIGTERM, inside a catch-all when
    ``swallow`` (as an import that catches everything does)."""
    path = folder / "signals_ik.py"
    send = "os.kill(os.getpid(), signal.SIGTERM)\ntime.sleep(0.5)"
    if swallow:
        send = "try:\n    " + send.replace("\n", "\n    ") + "\nexcept BaseException:\n    pass"
    path.write_text(
        "import os, signal, time\n"
        f"{send}\n"
        "from kr210_sim.robot.kinematics import nearest as solve\n"
    )
    return f"{path}:solve"


@pytest.mark.parametrize("swallow", [True, False])
def test_sigterm_during_start_up_stops_the_run_and_writes_a_report_of_no_cycles(
    tmp_path: Path, swallow: bool
) -> None:
    report = tmp_path / "run.json"
    args = ["--cycles", "3", "--ik", _ik_that_signals(tmp_path, swallow), "--report", str(report)]
    proc = _start(args, tmp_path)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, (out, err)
    assert "Traceback" not in err and "SIGTERM" in err
    assert "[ 1/" not in out  # no cycle ran
    data = json.loads(report.read_text())
    assert data["interrupted"] is True and data["interrupted_by"] == "SIGTERM"
    assert data["summary"]["cycles"] == 0


@pytest.mark.render
def test_sigint_to_the_process_alone_during_a_video_stops_it(tmp_path: Path) -> None:
    """`timeout -s INT` and supervisors signal the process, not its group: the render
    workers go on, the main process must still stop and keep what finished."""
    report, video = tmp_path / "run.json", tmp_path / "run.mp4"
    args = ["--cycles", "40", "--report", str(report), "--video", str(video)]
    video_args = ["--width", "160", "--height", "128", "--fps", "5", "--quality", "fast"]
    proc = _start([*args, *video_args], tmp_path)
    _first_cycle(proc)
    proc.send_signal(signal.SIGINT)  # to the process alone
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    data = json.loads(report.read_text())
    assert data["interrupted_by"] == "SIGINT" and 1 <= data["summary"]["cycles"] < 40


def test_an_ik_that_closes_stdout_and_changes_folder_loses_no_output(tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (tmp_path / "rude_ik.py").write_text(
        "import os, sys\n"
        "from kr210_sim.robot.kinematics import nearest\n"
        "def solve(T, q_ref):\n"
        f"    os.chdir({str(elsewhere)!r})\n"
        "    sys.stdout.close()\n"
        "    return nearest(T, q_ref)\n"
    )
    args = ["--cycles", "2", "--slot", "5", "--ik", "rude_ik.py:solve", "--report", "out/run.json"]
    proc = _start(args, tmp_path)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    data = json.loads((tmp_path / "out" / "run.json").read_text())  # where it was asked for
    assert data["summary"]["successes"] == 2
    assert list(elsewhere.iterdir()) == []


def _cycle_lines(out: str) -> int:
    return sum(1 for line in out.splitlines() if line.startswith("["))


def _burst(first: int, then: list[tuple[float, int]]) -> list[tuple[float, int]]:
    return [(0.0, first), *then]


# (what is sent after the first cycle line: pauses [s] and signals, to the process or its group)
SECOND_SIGNALS = {
    "SIGINT twice 2 ms apart": (_burst(signal.SIGINT, [(0.002, signal.SIGINT)]), False),
    # a CI cancel through `timeout`: the group is signalled, and timeout forwards it again
    "SIGTERM to the group twice 5 ms apart": (
        _burst(signal.SIGTERM, [(0.005, signal.SIGTERM)]),
        True,
    ),
    "SIGINT then one every ms for 0.2 s": (
        _burst(signal.SIGINT, [(0.001, signal.SIGINT)] * 200),
        False,
    ),
}


@pytest.mark.parametrize("case", list(SECOND_SIGNALS))
def test_further_signals_while_the_report_is_written_lose_nothing(
    tmp_path: Path, case: str
) -> None:
    report = tmp_path / "run.json"
    proc = _start(["--cycles", "40", "--report", str(report)], tmp_path)
    first = _first_cycle(proc)
    sends, group = SECOND_SIGNALS[case]
    for pause, signum in sends:
        time.sleep(pause)
        try:
            os.killpg(proc.pid, signum) if group else proc.send_signal(signum)
        except ProcessLookupError:  # it was done before the last one
            break
    out, err = proc.communicate(timeout=60)
    name = signal.Signals(sends[0][1]).name
    assert proc.returncode == 128 + sends[0][1], err
    done = _cycle_lines(first + out)
    assert err.splitlines() == [
        f"kr210_sim: interrupted after {done} cycles ({name}); writing the report of those"
    ]
    data = json.loads(report.read_text())  # written, whole
    assert data["interrupted"] is True and data["interrupted_by"] == name
    assert data["summary"]["cycles"] == len(data["cycles"]) == done >= 1
    assert f"report: {report}" in out
    assert [p.name for p in tmp_path.iterdir()] == ["run.json"]  # no temporary file left


#: A sitecustomize that holds the import of one module (``KR210_TEST_HOLD``) until a file
#: appears: the test signals the process at that moment of its start-up.
HOLD_AN_IMPORT = """
    import os, sys, time

    class _Hold:
        def find_spec(self, name, path=None, target=None):
            if name == os.environ["KR210_TEST_HOLD"]:
                sys.meta_path.remove(self)
                mark = os.environ["KR210_TEST_MARK"]
                open(mark, "w").close()
                deadline = time.monotonic() + 120
                while not os.path.exists(mark + ".go") and time.monotonic() < deadline:
                    time.sleep(0.005)
            return None

    sys.meta_path.insert(0, _Hold())
"""


def _held_at(module: str, args: list[str], tmp_path: Path) -> tuple[subprocess.Popen[str], Path]:
    """Start ``python -m kr210_sim ARGS`` and wait until its start-up imports ``module``."""
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(textwrap.dedent(HOLD_AN_IMPORT))
    mark = tmp_path / "at-the-import"
    env = {**os.environ, "PYTHONPATH": str(site), "KR210_TEST_HOLD": module}
    env["KR210_TEST_MARK"] = str(mark)
    proc = subprocess.Popen(
        [sys.executable, "-m", "kr210_sim", *args],
        cwd=tmp_path,
        env=env,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while not mark.exists():
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.005)
    return proc, mark


# Moments of run's start-up: the package's import (mujoco), the parsing of the arguments (the
# type of --cycles), the command's imports, and the job's (after the IK is loaded).
START_UP = {
    "mujoco": signal.SIGINT,
    "kr210_sim.sim.runner": signal.SIGTERM,
    "kr210_sim.api": signal.SIGTERM,
    "kr210_sim.jobs": signal.SIGINT,
}


@pytest.mark.parametrize("module", list(START_UP))
def test_a_signal_during_start_up_gives_a_report_of_no_cycles(tmp_path: Path, module: str) -> None:
    report = tmp_path / "run.json"
    report.write_text('{"an earlier run": true}')  # must not be taken for this run's
    proc, mark = _held_at(module, ["run", "--cycles", "3", "--report", str(report)], tmp_path)
    signum = START_UP[module]
    proc.send_signal(signum)
    time.sleep(0.005)
    proc.send_signal(signum)  # and a second, as a CI cancel sends
    Path(f"{mark}.go").touch()
    out, err = proc.communicate(timeout=120)
    name = signal.Signals(signum).name
    assert proc.returncode == 128 + signum, err
    assert err.splitlines() == [
        f"kr210_sim: interrupted before the first cycle ({name}); writing a report of no cycles"
    ]
    data = json.loads(report.read_text())
    assert data["interrupted"] is True and data["interrupted_by"] == name
    assert data["summary"]["cycles"] == 0 and data["cycles"] == [] and "[ 1/" not in out


def test_a_signal_during_start_up_of_a_command_without_cycles_writes_nothing(
    tmp_path: Path,
) -> None:
    """evaluate's report and its episodes file describe the earlier evaluation, as --resume
    reads them: a signal before this one began leaves both as they were."""
    report = tmp_path / "evaluate.json"
    report.write_text("earlier")
    proc, mark = _held_at("kr210_sim.cli", ["evaluate", "--report", str(report)], tmp_path)
    proc.send_signal(signal.SIGTERM)
    Path(f"{mark}.go").touch()
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert err.splitlines() == [
        "kr210_sim: interrupted (SIGTERM) before evaluate began; nothing written"
    ]
    assert report.read_text() == "earlier"
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "at-the-import",
        "at-the-import.go",
        "evaluate.json",
        "site",
    ]


def test_a_start_up_that_does_not_end_after_a_signal_is_ended_there(tmp_path: Path) -> None:
    from kr210_sim.util.interrupts import START_UP_GRACE_S

    proc, _ = _held_at("kr210_sim.cli", ["run", "--report", str(tmp_path / "r.json")], tmp_path)
    proc.send_signal(signal.SIGTERM)  # and the import it waits in never ends
    _, err = proc.communicate(timeout=60 + START_UP_GRACE_S)
    assert proc.returncode == 143
    assert err.splitlines() == [
        f"kr210_sim: interrupted (SIGTERM) during start-up, which had not ended "
        f"{START_UP_GRACE_S:g} s later; stopped there, nothing written"
    ]
    assert not (tmp_path / "r.json").exists()
