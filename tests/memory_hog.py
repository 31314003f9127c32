"""The code of a memory hog, for the tests of the jail's memory bound: written into a user's
file (test_jail, test_jail_class) or run alone (test_cgroups)."""

from __future__ import annotations

import textwrap


def hog(kids: int, mb: int, keep: int, within_s: float = 20.0) -> str:
    """Python code, at column 0, that forks ``kids`` children of ``mb`` MB each (written, so
    resident), waits up to ``within_s`` s for all but ``keep`` of them to end, kills the rest
    and leaves ``killed``: how many were killed by SIGKILL (the kernel's out-of-memory killer;
    nothing else here sends one before the end)."""
    return textwrap.dedent(
        f"""
        import os as _os, time as _time
        _kids = []
        for _ in range({kids}):
            _pid = _os.fork()
            if _pid == 0:
                _block = b"x" * ({mb} << 20)
                _time.sleep(600)
                _os._exit(0)
            _kids.append(_pid)
            _time.sleep(0.2)
        killed, _end = 0, _time.monotonic() + {within_s}
        while len(_kids) > {keep} and _time.monotonic() < _end:
            for _k in list(_kids):
                _pid, _status = _os.waitpid(_k, _os.WNOHANG)
                if _pid:
                    _kids.remove(_k)
                    killed += _os.WIFSIGNALED(_status) and _os.WTERMSIG(_status) == 9
            _time.sleep(0.05)
        for _k in _kids:
            _os.kill(_k, 9)
            _os.waitpid(_k, 0)
        """
    )
