"""The results table of a sweep: a CSV appended row by row, and a record of what produced it.

Each finished run is appended and flushed at once, so a sweep that is killed loses at most the runs
in flight (a half-written last line is dropped when the table is opened again). When every point has
a row, the table is rewritten sorted by point index, so equal sweeps give equal tables whatever the
order the runs finished in; only ``wall_s`` differs. Beside the table, ``<stem>.meta.json`` records
the sweep file, the base scene, the fingerprint of the runs' settings, the versions and the backend,
as the sweep was first started, and under ``resumes`` each later command that ran more of it or
finished it (one that finds the table finished, in the order of the sweep's points, changes nothing;
one whose sweep file lists an axis's values in another order sorts it again).
A ``.parquet`` output is written from the finished CSV (``<stem>.csv`` beside it) with pyarrow.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from cosim.errors import ScenarioError
from cosim.record.output import beside, remove_quietly, written_whole
from cosim.sweep.plan import yaml_value

NOT_RESULTS = ("interrupted", "unfinished")  # statuses of runs that a resumed sweep runs again
ROW_STATUSES = ("ok", "stopped", "failed", *NOT_RESULTS)  # what a run's row may say (RunResult's and those)


def cell(value: Any) -> str:
    """A value as CSV text: floats by their exact repr (nan, inf), lists in YAML flow style."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple, dict)):
        return yaml_value(value)
    return str(value)


def meta_path(output: Path) -> Path:
    return beside(output, ".meta.json")


def journal_path(output: Path) -> Path:
    return output if output.suffix == ".csv" else output.with_suffix(".csv")


def cannot(output: Path, exc: OSError | ValueError, action: str, then: str = "") -> ScenarioError:
    """The bad-input error for ``exc``, raised while trying to ``action`` (the table at ``output``, or the
    files beside it). It names the path the user gave; the file that failed, when it is another (the
    record beside the table, a folder), is named in the reason, by its final name, not a temporary one
    (:func:`cosim.record.output.written_whole` names it so). ``then``: what the user should know next,
    appended to the line. A ValueError is a path the system cannot take at all (a NUL character in it)."""
    if isinstance(exc, ValueError):
        return ScenarioError(f"cannot {action} here (not a path the system can take: {exc})", str(output))
    reason = exc.strerror or str(exc)
    if exc.filename is not None:
        failed = Path(os.fsdecode(exc.filename))
        if failed != output:
            where = f"{failed.name} beside it" if failed.parent == output.parent else str(failed)
            reason = f"{where}: {reason}"
    return ScenarioError(f"cannot {action} here ({reason}){then}", str(output))


class ResultTable:
    """The CSV journal of one sweep; ``open`` it (fresh or resumed), ``append`` rows, ``finish``."""

    def __init__(self, output: Path, columns: list[str], meta: dict[str, Any]):
        self.output = output
        self.path = journal_path(output)
        self.meta_path = meta_path(output)
        self.columns = columns
        self.meta = meta
        self._file: io.TextIOWrapper | None = None
        self._writer: Any = None
        self._made: list[Path] = []  # what open() created: the files and folders discard() removes
        self.already_finished = False  # resumed a table that was finished: open() and finish() write nothing

    def open(self, order: dict[str, int], fresh: bool = False) -> dict[str, dict[str, str]]:
        """Start the table, or resume it; returns the rows already there, by point id.

        ``order``: this sweep's point ids and their indices. Resuming needs the same fingerprint (the
        runs' settings) and columns; rows of points that are not in this sweep are an error (a different
        sweep wrote them).
        """
        rows: dict[str, dict[str, str]] = {}
        resume = self.path.exists() and not fresh
        started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
        if resume:
            try:
                rows, first = self._read_existing(set(order))
            except OSError as exc:
                raise cannot(self.output, exc, "read the sweep's table to resume it") from None
            if "finished" in first and set(rows) == set(order) and self._in_order(rows, order) and self.output.exists():
                # nothing to run and nothing to finish: the table and its record stay as they are
                self.meta, self.already_finished = first, True
                return rows
            # the record stays the first start's; this command is added to its resumes
            resumes = [*first.get("resumes", ()), {
                "command": self.meta.get("command", ""), "started": started, "rows_found": len(rows),
                "versions": self.meta.get("versions")}]
            self.meta = {**first, "resumes": resumes}
        made: list[Path] = []  # what this call creates: removed again if it fails halfway
        try:
            if not resume:
                for path in (self.path, self.output):
                    path.unlink(missing_ok=True)
            folder = self.path.parent
            while not folder.exists() and folder != folder.parent:
                made.append(folder)  # deepest first, the order to remove them in
                folder = folder.parent
            self.path.parent.mkdir(parents=True, exist_ok=True)
            if not resume:
                self.meta["started"] = started
            if not self.meta_path.exists():
                made.insert(0, self.meta_path)
            self._write_meta()
            new = not self.path.exists()
            if new:
                made.insert(0, self.path)
            self._file = open(self.path, "a", newline="", encoding="utf-8")  # closed in close()
            self._writer = csv.writer(self._file, lineterminator="\n")
            if new:
                self._writer.writerow(self.columns)
                self._file.flush()
        except (OSError, ValueError) as exc:  # (a ValueError: a NUL character in the path)
            self.close()
            for path in made:
                remove_quietly(path)
            raise cannot(self.output, exc, "write the sweep's results") from None
        self._made = made
        return rows

    @staticmethod
    def _in_order(rows: dict[str, dict[str, str]], order: dict[str, int]) -> bool:
        """Whether the table's rows (by point id, in the table's order) are this sweep's in its order, each
        with its index: a sweep file that lists an axis's values in another order gives its points
        other indices, and the table finished for the old order is sorted again."""
        return [(point, row["index"]) for point, row in rows.items()] == sorted(
            ((point, str(order[point])) for point in rows), key=lambda item: order[item[0]])

    @staticmethod
    def _rows_with_lines(reader: Any) -> Iterator[tuple[int, int, list[str]]]:
        """(the lines a row starts and ends on, 1-based, its fields) for each row ``reader`` reads."""
        first = reader.line_num + 1
        for values in reader:
            yield first, reader.line_num, values
            first = reader.line_num + 1

    def _swallows_rows(self, raw: bytes, first_line: int, known_ids: set[str]) -> bool:
        """Whether the text from line ``first_line`` of ``raw`` on holds, after its first line, a line
        that is a whole row of this sweep by itself (its fields as many as the columns, its index a
        number, its point one of the sweep's and its status one a run gives): the rows after a quote
        never closed, not the rest of one row (whose reason may hold commas on a line of its own)."""
        index, point, status = (self.columns.index(c) for c in ("index", "point_id", "status"))
        for line in raw[_offset_of_line(raw, first_line):].decode("utf-8").split("\n")[1:]:
            try:
                values = next(csv.reader([line]), [])
            except csv.Error:  # (a field over the csv module's limit: no row of this sweep)
                continue
            if (len(values) == len(self.columns) and values[index].isdigit() and values[point] in known_ids
                    and values[status] in ROW_STATUSES):
                return True
        return False

    def _read_existing(self, known_ids: set[str]) -> tuple[dict[str, dict[str, str]], dict[str, Any]]:
        """(the table's whole rows by point id, its record) of a table this sweep wrote."""
        where = str(self.path)
        if self.path.is_dir():
            raise ScenarioError("is a folder, not a results table: give -o a .csv or .parquet file name", where)
        try:
            meta = json.loads(self.meta_path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            raise ScenarioError(f"exists but {self.meta_path.name} beside it is missing or unreadable, so "
                                "it cannot be resumed; use --fresh to start over or -o for another file",
                                where) from None
        if meta.get("fingerprint") != self.meta["fingerprint"]:
            raise ScenarioError("holds the results of a different sweep (its scene, set, derived, metrics or "
                                "columns differ); use --fresh to start over or -o for another file", where)
        raw = self.path.read_bytes()
        try:  # the whole rows (a row cut short may end inside a character), before anything is cut off below
            raw[: raw.rfind(b"\n") + 1].decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ScenarioError(f"is not UTF-8 text (byte {exc.start}), so not a table this sweep wrote; use "
                                "--fresh to start over or -o for another file", where) from None
        if raw and not raw.endswith(b"\n"):  # a row cut short by a kill: drop it
            raw = raw[: raw.rfind(b"\n") + 1]
            with open(self.path, "r+b") as f:
                f.truncate(len(raw))
        reader = csv.reader(io.StringIO(raw.decode("utf-8")))
        header = next(reader, None)
        if header is None:  # killed before the header was written
            self.path.unlink()
            return {}, meta
        if header != self.columns:
            raise ScenarioError("has other columns than this sweep writes; use --fresh to start over or -o "
                                "for another file", where)
        rows: dict[str, dict[str, str]] = {}
        strangers = []
        try:
            parsed = list(self._rows_with_lines(reader))
        except csv.Error as exc:  # a quote never closed over more than 128 KiB: a field beyond the limit
            raise ScenarioError(f"line {reader.line_num}: not a table this sweep wrote ({exc}); use --fresh to "
                                "start over or -o for another file", where) from None
        for k, (first_line, last_line, values) in enumerate(parsed):
            if len(values) != len(header):
                if k == len(parsed) - 1 and not self._swallows_rows(raw, first_line, known_ids):
                    # a row cut short after a line break inside its reason: dropped, so that the rows
                    # written next start on a line of their own
                    raw = raw[: _offset_of_line(raw, first_line)]
                    with open(self.path, "r+b") as f:
                        f.truncate(len(raw))
                    break
                # (a quote opened and never closed takes in every row after it: appended to, the
                # table held one row whose reason was all the others)
                raise ScenarioError(f"line {first_line}: a row of {len(values)} fields where the table has "
                                    f"{len(header)} (a quote opened and never closed, or a field added or left "
                                    "out): not a table this sweep wrote; use --fresh to start over or -o for "
                                    "another file", where)
            row = dict(zip(header, values, strict=True))
            if row["status"] not in ROW_STATUSES:  # a hand-edited table: "6 weird" was summed as a status
                # (the reader's line, where the row ends: a reason may run over several lines)
                raise ScenarioError(f"line {last_line}: status {row['status']!r} is not one a run gives "
                                    f"({', '.join(ROW_STATUSES)}); use --fresh to start over or -o for another "
                                    "file", where)
            if row["point_id"] not in known_ids:
                strangers.append(row["point_id"])
            kept = rows.get(row["point_id"])
            # a point run again after a stop is in the table twice until the sweep ends: its result wins
            if kept is None or (kept["status"] in NOT_RESULTS and row["status"] not in NOT_RESULTS):
                rows[row["point_id"]] = row
        if strangers:
            raise ScenarioError(f"holds {len(strangers)} points that are not in this sweep (e.g. "
                                f"{strangers[0]}); use --fresh to start over or -o for another file", where)
        return rows, meta

    def append(self, row: dict[str, Any]) -> None:
        assert self._writer is not None and self._file is not None, "open() the table first"
        self._writer.writerow([cell(row.get(c)) for c in self.columns])
        self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
            self._writer = None

    def discard(self) -> None:
        """Close the table and remove what ``open`` created (a table started for a sweep that cannot go
        on); a resumed table is kept as it was."""
        self.close()
        for path in self._made:
            remove_quietly(path)
        self._made = []

    def finish(self, order: dict[str, int], summary: dict[str, Any]) -> list[dict[str, str]]:
        """Rewrite the table sorted by point index (and the Parquet file if asked); returns the rows.

        If that cannot be written, the rows stay in the journal as they were, and a ScenarioError says
        so: running the sweep again resumes with nothing left to run and finishes it.
        """
        self.close()
        if self.already_finished:
            return self._sorted_rows(order)
        try:
            return self._finish(order, summary)
        except OSError as exc:
            raise cannot(self.output, exc, "write the sweep's finished table",
                         "; its rows are kept: run the same command again to finish it") from None

    def _sorted_rows(self, order: dict[str, int]) -> list[dict[str, str]]:
        """The journal's rows of this sweep's points, one a point, by point index."""
        with open(self.path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            by_id: dict[str, dict[str, str]] = {}
            for row in reader:
                if None not in row and row["point_id"] in order:
                    by_id.setdefault(row["point_id"], row)
        rows = sorted(by_id.values(), key=lambda r: order[r["point_id"]])
        for row in rows:
            row["index"] = str(order[row["point_id"]])
        return rows

    def _finish(self, order: dict[str, int], summary: dict[str, Any]) -> list[dict[str, str]]:
        rows = self._sorted_rows(order)
        with written_whole(self.path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, self.columns, lineterminator="\n")
            writer.writeheader()
            writer.writerows(rows)
        self.meta.update(summary, finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"))
        self._write_meta()
        if self.output.suffix == ".parquet":
            write_parquet(self.output, rows, self.columns, self.meta)
        return rows

    def _write_meta(self) -> None:
        with written_whole(self.meta_path) as tmp:
            tmp.write_text(json.dumps(self.meta, indent=2, default=str) + "\n", encoding="utf-8")


def _parses(values: list[str], kind: type) -> bool:
    try:
        for v in values:
            kind(v)
    except ValueError:
        return False
    return True


def _typed(values: list[str]) -> tuple[str, list[Any]]:
    """A column's type (int64, float64 or string) and its values, from the CSV text."""
    present = [v for v in values if v != ""]
    if present and _parses(present, int):
        return "int64", [int(v) if v != "" else None for v in values]
    if present and _parses(present, float):
        return "float64", [float(v) if v != "" else math.nan for v in values]
    return "string", values


def write_parquet(path: Path, rows: list[dict[str, str]], columns: list[str], meta: dict[str, Any]) -> None:
    """The finished table as Parquet, typed per column, with the sweep's record in its metadata."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays, fields = [], []
    for name in columns:
        kind, values = _typed([row[name] for row in rows])
        arrays.append(pa.array(values, type=getattr(pa, kind)()))
        fields.append(pa.field(name, getattr(pa, kind)()))
    schema = pa.schema(fields, metadata={"cosim.sweep": json.dumps(meta, default=str)})
    with written_whole(path) as tmp:
        pq.write_table(pa.Table.from_arrays(arrays, schema=schema), tmp)


def _offset_of_line(raw: bytes, line: int) -> int:
    """The byte offset in ``raw`` where its 1-based ``line`` starts."""
    offset = 0
    for _ in range(line - 1):
        offset = raw.index(b"\n", offset) + 1
    return offset
