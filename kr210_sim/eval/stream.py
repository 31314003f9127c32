"""The episodes file: every finished episode's record, one JSON line each, written as it comes.

``<report stem>.episodes.jsonl`` beside the report. Its first line is a header naming what the
records depend on (seed, randomisation, scene, library versions); then one record per line in
the order episodes finished. Each line is flushed as it is written, so a killed evaluation (even
``kill -9``) loses only the episodes in flight, and ``evaluate --resume`` continues from the
file. A line cut short by a kill is dropped when the file is read back.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType
from typing import IO, Any

from kr210_sim.errors import ConfigError

log = logging.getLogger(__name__)

#: ``kind`` of the header line.
HEADER_KIND = "kr210_sim.evaluate.episodes"


def episodes_path(report: Path) -> Path:
    """The episodes file beside ``report``: ``x/evaluate.json`` -> ``x/evaluate.episodes.jsonl``."""
    return report.with_name(report.stem + ".episodes.jsonl")


def header(identity: dict[str, Any]) -> dict[str, Any]:
    """The header line for an evaluation whose episodes depend on ``identity``."""
    return {"kind": HEADER_KIND, **identity}


def _line(obj: dict[str, Any]) -> str:
    return json.dumps(obj, sort_keys=True, allow_nan=False) + "\n"


def _whole(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 0


def record_problem(record: Any) -> str:
    """Why ``record`` is not an episode record, or "" when it may be one: an object whose
    ``episode`` and ``seed`` are whole numbers >= 0 and whose ``success`` is true or false (the
    rest is the cycle record's, checked as the summary counts it)."""
    if not isinstance(record, dict):
        return f"a JSON {type(record).__name__}, not an object"
    for key, ok, what in (
        ("episode", _whole, "a whole number >= 0"),
        ("seed", _whole, "a whole number >= 0"),
        ("success", lambda v: isinstance(v, bool), "true or false"),
    ):
        if key not in record:
            return f"no {key!r}"
        if not ok(record[key]):
            return f"{key!r} is {record[key]!r}, not {what}"
    return ""


def read_records(path: Path, identity: dict[str, Any]) -> Iterator[dict[str, Any]]:
    """The records in the episodes file at ``path``, after checking that it belongs here.

    A last line cut short (the writer was killed mid-line) is removed from the file; any other
    line that is not an episode record (:func:`record_problem`: a hand-edited ``"episode": -1``
    or ``"episode": "3"``, a list) is an error, never skipped.

    Args:
        path: The episodes file.
        identity: What the records must depend on (see :func:`header`).

    Raises:
        ConfigError: When the file belongs to another evaluation, a line is corrupt or a line
            is not an episode record.
    """
    good = 0  # bytes of whole, valid lines
    with path.open("rb") as fh:
        first = fh.readline()
        try:
            head = json.loads(first)
        except ValueError:
            head = None
        want = header(identity)
        if not isinstance(head, dict) or head.get("kind") != HEADER_KIND:
            raise ConfigError(f"{path} is not an episodes file; remove it or drop --resume")
        if head != want:
            diff = sorted(k for k in want.keys() | head.keys() if head.get(k) != want.get(k))
            raise ConfigError(
                f"cannot resume from {path}: its episodes differ in {', '.join(diff)}; "
                "run without --resume to start afresh"
            )
        good = len(first)
        number = 1
        for raw in fh:
            number += 1
            try:
                record = json.loads(raw)
                whole = raw.endswith(b"\n")
            except ValueError:
                whole = False
            if not whole:
                if fh.read(1):
                    raise ConfigError(f"{path}: line {number} is corrupt")
                log.warning("%s: dropping line %d, cut short", path, number)
                break
            problem = record_problem(record)
            if problem:
                raise ConfigError(
                    f"{path}: line {number} is not an episode record ({problem}); "
                    "run without --resume to start afresh"
                )
            good += len(raw)
            yield record
    if path.stat().st_size != good:
        with path.open("r+b") as fh:
            fh.truncate(good)


class EpisodeWriter:
    """Appends records to an episodes file, one flushed line each.

    Args:
        path: The episodes file.
        identity: What the records depend on (written as the header of a new file).
        append: Continue the existing file (after :func:`read_records`) instead of starting one.
    """

    def __init__(self, path: Path, identity: dict[str, Any], append: bool) -> None:
        self.path = path
        self._fh: IO[str]
        try:
            self._fh = path.open("a" if append else "w", encoding="utf-8")
        except OSError as exc:
            raise ConfigError(f"cannot write {path}: {exc.strerror}") from exc
        if not append:
            self._fh.write(_line(header(identity)))
            self._fh.flush()

    def write(self, records: list[dict[str, Any]]) -> None:
        """Append ``records`` and flush them to the operating system."""
        self._fh.write("".join(_line(r) for r in records))
        self._fh.flush()

    def close(self) -> None:
        """Close the file."""
        self._fh.close()

    def __enter__(self) -> EpisodeWriter:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
