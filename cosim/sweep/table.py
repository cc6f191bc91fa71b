"""The results table of a sweep: a CSV appended row by row, and a record of what produced it.

Each finished run is appended and flushed at once, so a sweep that is killed loses at most the runs
in flight (a half-written last line is dropped when the table is opened again; a whole row missing only
its line break is kept). A row of a run that was interrupted is no result: its point runs again. An
extended table (more points) is finished again, whatever an earlier finish wrote. When every point has
a row, the table is rewritten sorted by point index, so equal sweeps give equal tables whatever the
order the runs finished in; only ``wall_s`` differs. Beside the table, ``<stem>.meta.json`` records
the sweep file, the base scene, the fingerprint of the runs' settings, the versions and the backend,
as the sweep was first started, and under ``resumes`` each later command that ran more of it or
finished it (one that finds the table finished, in the order of the sweep's points, changes nothing;
one whose sweep file lists an axis's values in another order sorts it again).
A ``.parquet`` output is written from the finished CSV (``<stem>.journal.csv`` beside it) with pyarrow, each
column typed by what the sweep declares it to hold (never guessed from its values: a point id such as
``11e755065873`` read as a number was the double ``inf``).

One sweep at a time writes a table: it holds an exclusive lock on ``<stem>.lock`` beside it from
``open`` to ``release`` (two sweeps appending to one table lost rows and both said they were done).
"""

from __future__ import annotations

import csv
import fcntl
import io
import json
import math
import os
import time
from collections import deque
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from cosim.errors import CosimError, ScenarioError, counted
from cosim.params import whole_digits
from cosim.record.output import beside, refuse_read_only, remove_quietly, written_whole
from cosim.sweep.backends import MACHINE_LIMITS
from cosim.sweep.plan import yaml_value

NOT_RESULTS = ("interrupted", "unfinished")  # statuses of runs that a resumed sweep runs again
ROW_STATUSES = ("ok", "stopped", "failed", *NOT_RESULTS)  # what a run's row may say (RunResult's and those)
# the Parquet types of the table's fixed columns; a metric's comes from its kind, an axis's from its values
FIXED_KINDS = {"index": "int64", "point_id": "string", "status": "string", "reason": "string",
               "error_type": "string", "sim_time_s": "float64", "ticks": "int64", "recording": "string",
               "wall_s": "float64"}
HEADER_MAX = 1 << 20  # [characters] read of a table's first line, to know whose it is (a header is far shorter)


class MachineLimit(CosimError):
    """A write of the sweep's table refused for want of room (the disk full, a quota, a file-size
    limit): not the user's input (exit 1), and the same command resumes once there is room."""

    exit_code = 1


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
    """The CSV the rows are appended to: the table itself, or beside a Parquet table ``<stem>.journal.csv``
    (it was ``<stem>.csv``: a user's table of that name, another sweep's, was taken for the journal,
    refused as another sweep's, and replaced by ``--fresh``)."""
    return output if output.suffix == ".csv" else beside(output, ".journal.csv")


def strangers_said(strangers: list[str]) -> str:
    """Why a table holding rows of the points ``strangers`` (their ids), which this sweep has not, is
    not resumed (an axis that lost values)."""
    return (f"holds {len(strangers)} points that are not in this sweep (e.g. {strangers[0]}); use --fresh to "
            "start over or -o for another file")


def run_again(fresh: bool) -> str:
    """How to go on with a table a sweep has begun: after --fresh the same command again would discard
    the rows it kept."""
    return "run the command again without --fresh" if fresh else "run the same command again"


def no_record(meta: Path) -> str:
    """Why a table whose record ``meta`` cannot be read cannot be resumed."""
    return (f"exists but {meta.name} beside it is missing or unreadable, so it cannot be resumed; use --fresh "
            "to start over or -o for another file")


def not_this_sweeps(record: dict[str, Any], fingerprint: str, columns: list[str]) -> str:
    """Why a table whose record (its meta file) is ``record`` cannot be resumed by a sweep of this
    ``fingerprint`` and ``columns`` ('' if it can)."""
    if record.get("fingerprint") == fingerprint:
        return ""
    theirs, mine = list(record.get("columns") or ()), list(columns)
    if [c for c in theirs if c != "recording"] == [c for c in mine if c != "recording"] and theirs != mine:
        # the same sweep, started with --record and resumed without it, or the other way round
        started, rows = ("with", "name their") if "recording" in theirs else ("without", "have no")
        return (f"was started {started} --record (its rows {rows} recordings): resume it {started} --record, or "
                "use --fresh to start over or -o for another file")
    return ("holds the results of a different sweep (its scene, set, derived, metrics or columns differ); use "
            "--fresh to start over or -o for another file")


def figure_path(output: Path) -> Path:
    """Where a sweep's figure is drawn: beside its table, as a PNG."""
    return output.with_suffix(".png")


def runs_folder(output: Path) -> Path:
    """Where a sweep's recordings go (``--record``): a folder beside its table."""
    return beside(output, "_runs")


def lock_path(output: Path) -> Path:
    return beside(output, ".lock")


def _header(path: Path) -> list[str] | None:
    """The first row of the CSV at ``path`` (None if it cannot be read as one)."""
    try:
        with open(path, newline="", encoding="utf-8") as f:
            return next(csv.reader([f.readline(HEADER_MAX)]), None)
    except (OSError, ValueError, csv.Error):
        return None


def _record_owner(output: Path, record: dict[str, Any]) -> str | None:
    """The name of the table whose record ``record`` (the meta file beside ``output``) is: the one it
    names, or, for a record written before it named its table, ``output`` if its journal is there, else
    the table of the other format beside it if that one's header is the record's columns; None if
    neither (a record left by a table since removed)."""
    named = record.get("table")
    if isinstance(named, str):
        return named
    if journal_path(output).exists():
        return output.name
    other = output.with_suffix(".parquet" if output.suffix == ".csv" else ".csv")
    return other.name if _header(journal_path(other)) == record.get("columns") else None


def refused_output(output: Path, fresh: bool) -> str:
    """Why a sweep cannot start or resume its table at ``output`` at all ('' if nothing refuses it here):

    - the files beside it are another table's: ``res.csv`` and ``res.parquet`` in one folder share their
      record, lock, figure and runs folder (all named by the stem), and a sweep of one overwrote the
      other's record and figure, which could then no longer be resumed; ``--fresh`` does not take them
      (it discards this table, not the other). Refused rather than named apart, so that every table
      already written keeps its side files' names and resumes;
    - a Parquet table whose journal is gone: it cannot be resumed, and was deleted as if ``--fresh``
      had been given (a CSV table without its record is refused so already).
    """
    meta = meta_path(output)
    try:
        record = json.loads(meta.read_text(encoding="utf-8")) if meta.is_file() else None
    except (OSError, ValueError):
        record = None  # said by the resume that needs it (no_record); a fresh start replaces it
    owner = _record_owner(output, record) if isinstance(record, dict) else None
    if owner is not None and owner != output.name:
        # (a record copied or renamed with its table names the table it was made for, of another stem)
        theirs = output.with_name(owner)
        if meta_path(theirs) == meta and (journal_path(theirs).exists() or theirs.exists()):
            return (f"{meta.name} beside it is the record of {owner}, another sweep's table of the same stem (the "
                    f"two would share their record, figure {figure_path(output).name}, lock and runs folder); give "
                    "-o another name")
    if not fresh and not journal_path(output).exists() and output.exists() and not output.is_dir():
        return (f"exists but its journal {journal_path(output).name} beside it is missing, so it cannot be "
                "resumed; use --fresh to start over or -o for another file")
    for path in (output, meta):  # rewritten whole as the sweep finishes: refused then, after every run
        try:
            refuse_read_only(path)
        except PermissionError:
            return (f"{'' if path == output else path.name + ' beside it '}is read-only, and a sweep rewrites it as "
                    "it finishes; make it writable or give -o another name")
    return ""


def cannot(output: Path, exc: OSError | ValueError, action: str, then: str = "") -> ScenarioError | MachineLimit:
    """The error for ``exc``, raised while trying to ``action`` (the table at ``output``, or the files
    beside it): bad input (a ScenarioError), or a MachineLimit when the machine had no room, which says
    that the same command resumes. It names the path the user gave; the file that failed, when it is
    another (the record beside the table, a folder), is named in the reason, by its final name, not a
    temporary one (:func:`cosim.record.output.written_whole` names it so). ``then``: what the user should
    know next, appended to the line. A ValueError is a path the system cannot take at all (a NUL
    character in it)."""
    if isinstance(exc, ValueError):
        return ScenarioError(f"cannot {action} here (not a path the system can take: {exc})", str(output))
    reason = exc.strerror or str(exc)
    if exc.filename is not None:
        failed = Path(os.fsdecode(exc.filename))
        if failed != output:
            where = f"{failed.name} beside it" if failed.parent == output.parent else str(failed)
            reason = f"{where}: {reason}"
    if exc.errno in MACHINE_LIMITS:  # the machine's limit, not the user's input: exit 1, and say how to go on
        then = then or "; run the same command again once there is room to resume the sweep"
        return MachineLimit(f"{output}: cannot {action} ({reason}){then}")
    return ScenarioError(f"cannot {action} here ({reason}){then}", str(output))


class ResultTable:
    """The CSV journal of one sweep; ``open`` it (fresh or resumed), ``append`` rows, ``finish``, and
    ``release`` it (its lock) once done with it.

    ``kinds``: each column's Parquet type (int64, float64, bool or string; a metric's "number": int64
    or float64 as its values are); a column not in it is typed by its values. ``axis_values``: each
    point's axis values, by point id: a row whose axis cells are not its point's (an edited table) is
    refused on resume.
    """

    def __init__(self, output: Path, columns: list[str], meta: dict[str, Any], kinds: dict[str, str] | None = None,
                 axis_values: dict[str, dict[str, Any]] | None = None):
        self.output = output
        self.path = journal_path(output)
        self.meta_path = meta_path(output)
        self.columns = columns
        # the record names its table: a table of the same stem and the other format shares its name
        self.meta = {**meta, "table": output.name}
        self.kinds = kinds or {}
        self.axis_values = axis_values or {}
        self._file: io.TextIOWrapper | None = None
        self._writer: Any = None
        self._lock: int | None = None  # the descriptor of the lock file, held from open() to release()
        self._made: list[Path] = []  # what open() created: the files and folders discard() removes
        self._journal_rows = 0  # the rows the journal held when opened (a point run again is in it twice)
        self.dropped = 0  # rows of runs that were interrupted, found on resume: not results, their points run again
        self.already_finished = False  # resumed a table that was finished: open() and finish() write nothing
        self.fresh = False  # opened with --fresh: what is said of running it again leaves that out

    def open(self, order: dict[str, int], fresh: bool = False) -> dict[str, dict[str, str]]:
        """Start the table, or resume it; returns the rows already there, by point id.

        ``order``: this sweep's point ids and their indices. Resuming needs the same fingerprint (the
        runs' settings) and columns; rows of points that are not in this sweep are an error (a different
        sweep wrote them). Rows of runs that were interrupted are no results: left out (``dropped``
        counts them), their points run again. Raises ScenarioError while another sweep writes the table.
        """
        self.fresh = fresh
        made = self._make_folders()  # what this call creates: removed again if it fails halfway
        try:
            self._take_lock()
            return self._open(order, fresh, made)
        except BaseException:
            self.release()
            for path in made:
                remove_quietly(path)
            raise

    def _recordings_listed(self) -> list[Path]:
        """The recordings the journal's rows name that lie in this table's runs folder (none when the
        journal cannot be read, or has no recording column)."""
        folder = runs_folder(self.output)
        try:
            with open(self.path, newline="", encoding="utf-8") as f:
                named = [row.get("recording") or "" for row in csv.DictReader(f)]
        except (OSError, ValueError, csv.Error):
            return []
        # by file name in the folder (a row gives the path as the command that ran it saw it)
        return [folder / Path(name).name for name in named if name and Path(name).parent.name == folder.name]

    def _open(self, order: dict[str, int], fresh: bool, made: list[Path]) -> dict[str, dict[str, str]]:
        refused = refused_output(self.output, fresh)
        if refused:
            raise ScenarioError(refused, str(self.output))
        rows: dict[str, dict[str, str]] = {}
        resume = self.path.exists() and not fresh
        started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
        if resume:
            try:
                rows, first = self._read_existing(set(order))
            except OSError as exc:
                raise cannot(self.output, exc, "read the sweep's table to resume it") from None
            if ("finished" in first and set(rows) == set(order) and self._journal_rows == len(rows)
                    and self._in_order(rows, order) and self.output.exists()):
                # nothing to run and nothing to finish: the table and its record stay as they are
                self.meta, self.already_finished = first, True
                return rows
            # the record stays the first start's; this command is added to its resumes. It is finished
            # again for this sweep's points: an earlier finish's summary (of fewer points, say) is not
            # this table's until then, so that a finish cut short is done by the next command
            resumes = [*first.get("resumes", ()), {
                "command": self.meta.get("command", ""), "started": started, "rows_found": len(rows),
                "points": len(order), "versions": self.meta.get("versions")}]
            kept = {key: value for key, value in first.items() if key not in ("finished", "counts")}
            kept.setdefault("table", self.output.name)  # (a record from before tables were named in it)
            self.meta = {**kept, "resumes": resumes}
        try:
            if not resume:
                # what the table before drew and recorded goes with it: its figure, and the recordings its
                # rows name in the runs' folder (a figure of another sweep stood beside the new table)
                drawn = [figure_path(self.output), *self._recordings_listed()] if self.path.exists() else []
                for path in (self.path, self.output, *(p for p in drawn if p.is_file())):
                    path.unlink(missing_ok=True)
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
            raise cannot(self.output, exc, "write the sweep's results") from None
        self._made = made
        return rows

    def _make_folders(self) -> list[Path]:
        """Make the table's folder, for its lock; the folders made, deepest first (the order to remove
        them in). Never raises: a folder that cannot be made is said by the writes that need it."""
        made = []
        folder = self.path.parent
        try:
            while not folder.exists() and folder != folder.parent:
                made.append(folder)
                folder = folder.parent
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except (OSError, ValueError):
            for path in made:
                remove_quietly(path)
            return []
        return made

    def _take_lock(self) -> None:
        """Hold the exclusive lock of the table (``<stem>.lock`` beside it) until ``release``; a
        ScenarioError if another sweep holds it. The system lets go of a lock when its process ends,
        so a sweep that was killed never blocks the next. The lock file is removed on release, so
        each lock taken is checked to be on the file still there (not one removed meanwhile)."""
        path = lock_path(self.output)
        for _ in range(100):
            try:
                fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
            except (OSError, ValueError):
                # no lock can be made here (a read-only folder, a path the system cannot take): the
                # writes that follow say why, or there is nothing to write (a finished table)
                return
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                same = os.path.samestat(os.fstat(fd), os.stat(path))
            except BlockingIOError:
                os.close(fd)
                raise ScenarioError(f"another sweep is writing it now (it holds {path.name} beside it); wait "
                                    "for it to end, or give -o another file", str(self.output)) from None
            except OSError:  # (the lock file removed meanwhile: taken again below)
                same = False
            if same:
                self._lock = fd
                return
            os.close(fd)

    def release(self) -> None:
        """Close the table and let go of its lock (removing the lock file, while still holding it)."""
        self.close()
        if self._lock is not None:
            remove_quietly(lock_path(self.output))
            os.close(self._lock)
            self._lock = None

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

    def _ends_in_a_whole_row(self, raw: bytes, known_ids: set[str]) -> bool:
        """Whether the journal ``raw``, which has no line break at its end, ends in a whole row of this
        sweep: as many fields as the columns, no quote left open, its index a number, its point one of
        the sweep's, its status one a run gives, and its last field (the run's wall time) a float as
        :func:`cell` writes one (a row cut inside it, ``1.`` or ``1`` of ``1.25``, is no whole row)."""
        try:
            rows = deque(csv.reader(io.StringIO(raw.decode("utf-8")), strict=True), maxlen=1)
            last = rows[0] if rows else []
            whole_wall = bool(last) and repr(float(last[-1])) == last[-1]
        except (UnicodeDecodeError, csv.Error, ValueError):  # (strict: a quote left open is an error)
            return False
        if len(last) != len(self.columns) or not whole_wall:
            return False
        row = dict(zip(self.columns, last, strict=True))
        return whole_digits(row["index"]) and row["point_id"] in known_ids and row["status"] in ROW_STATUSES

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
            if (len(values) == len(self.columns) and whole_digits(values[index]) and values[point] in known_ids
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
            raise ScenarioError(no_record(self.meta_path), where) from None
        foreign = not_this_sweeps(meta, self.meta["fingerprint"], self.columns)
        if foreign:
            raise ScenarioError(foreign, where)
        raw = self.path.read_bytes()
        try:  # the whole rows (a row cut short may end inside a character), before anything is cut off below
            raw[: raw.rfind(b"\n") + 1].decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ScenarioError(f"is not UTF-8 text (byte {exc.start}), so not a table this sweep wrote; use "
                                "--fresh to start over or -o for another file", where) from None
        if raw and not raw.endswith(b"\n"):
            if self._ends_in_a_whole_row(raw, known_ids):
                # a whole row with no line break after it (an editor left it out): kept, ended
                raw += b"\n"
                with open(self.path, "ab") as f:
                    f.write(b"\n")
            else:  # a row cut short by a kill: drop it
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
            self._check_axis_cells(row, last_line)
            self._journal_rows += 1
            kept = rows.get(row["point_id"])
            # a point run again after a stop is in the table twice until the sweep ends: its result wins
            if kept is None or (kept["status"] in NOT_RESULTS and row["status"] not in NOT_RESULTS):
                rows[row["point_id"]] = row
        if strangers:
            raise ScenarioError(strangers_said(strangers), where)
        # a run that was interrupted is no result of its point (README: it runs again on resume)
        results = {point: row for point, row in rows.items() if row["status"] not in NOT_RESULTS}
        self.dropped = len(rows) - len(results)
        return results, meta

    def _check_axis_cells(self, row: dict[str, str], line: int) -> None:
        """Refuse a row whose axis values are not its point's (the table edited by hand: the row would be
        kept, counted and plotted at the edited value as the result of a point that never ran there)."""
        for column, value in self.axis_values.get(row["point_id"], {}).items():
            expected = cell(value)
            if row[column] != expected:
                raise ScenarioError(f"line {line}: column {column} holds {row[column]!r} where point "
                                    f"{row['point_id']} has {expected!r} (the table was edited?); the row is not "
                                    "that point's result: use --fresh to start over or -o for another file",
                                    str(self.path))

    def append(self, row: dict[str, Any]) -> None:
        """Write ``row`` at the end of the journal, at once. If the machine refuses it (the disk full), the
        journal is cut back to its rows before it, closed, and the OSError (naming the journal) raised:
        no part of a row is left to be read as one on resume."""
        assert self._writer is not None and self._file is not None, "open() the table first"
        before = os.fstat(self._file.fileno()).st_size
        try:
            self._writer.writerow([cell(row.get(c)) for c in self.columns])
            self._file.flush()
        except OSError as exc:
            try:
                self._file.close()  # (tries to write the row again, and fails again)
            except OSError:
                pass
            self._file = self._writer = None
            try:
                os.truncate(self.path, before)
            except OSError:
                pass  # a part row left is dropped on resume, unless it ends inside its last field
            if exc.filename is None:
                exc.filename = str(self.path)
            raise

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
            self._writer = None

    def discard(self) -> None:
        """Close the table, let go of its lock and remove what ``open`` created (a table started for a
        sweep that cannot go on); a resumed table is kept as it was."""
        self.release()
        for path in self._made:
            remove_quietly(path)
        self._made = []

    def finish(self, order: dict[str, int], summary: dict[str, Any]) -> list[dict[str, str]]:
        """Rewrite the table sorted by point index (and the Parquet file if asked); returns the rows.

        If that cannot be written, the rows stay in the journal as they were, and the error (a
        ScenarioError, or a MachineLimit for a full disk) says so: running the sweep again resumes with
        nothing left to run and finishes it.
        """
        self.close()
        if self.already_finished:
            return self._sorted_rows(order)
        try:
            return self._finish(order, summary)
        except OSError as exc:
            raise cannot(self.output, exc, "write the sweep's finished table",
                         f"; its rows are kept: {run_again(self.fresh)} to finish it") from None

    def _sorted_rows(self, order: dict[str, int]) -> list[dict[str, str]]:
        """The journal's results of this sweep's points, one a point, by point index. A row of a point
        not in this sweep (written by a command that took no lock) is refused, not dropped unsaid."""
        with open(self.path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            by_id: dict[str, dict[str, str]] = {}
            strangers = []
            for row in reader:
                if None in row or row["status"] in NOT_RESULTS:
                    continue
                if row["point_id"] not in order:
                    strangers.append(row["point_id"])
                by_id.setdefault(row["point_id"], row)
        if strangers:
            raise ScenarioError(f"holds {counted(len(strangers), 'row')} of points that are not in this sweep (e.g. "
                                f"{strangers[0]}), written by another command meanwhile; the table is left as "
                                "it is, unfinished: use --fresh to start over or -o for another file",
                                str(self.path))
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
        if self.output.suffix == ".parquet":
            write_parquet(self.output, rows, self.columns, self.meta, self.kinds)
        # the record says finished last: a finish cut short before it is done again by the next command
        self._write_meta()
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


def _typed(values: list[str], kind: str | None = None) -> tuple[str, list[Any]]:
    """A column's type (int64, float64, bool or string) and its values, from the CSV text.

    ``kind``: what the sweep declares the column to hold: one of those types, or "number" (int64 if
    every value is a whole number, else float64); None: typed by the values (int64, float64 or string),
    for a table whose kinds are not known. A value the declared type cannot take (a cell edited by
    hand) leaves the column text."""
    present = [v for v in values if v != ""]
    if kind is None:
        kind = "number" if present and _parses(present, float) else "string"
    if kind == "number":
        kind = "int64" if present and _parses(present, int) else "float64"
    if kind == "bool" and set(present) <= {"true", "false"}:
        return "bool", [v == "true" if v != "" else None for v in values]
    if kind == "int64" and _parses(present, int):
        return "int64", [int(v) if v != "" else None for v in values]
    if kind == "float64" and _parses(present, float):
        return "float64", [float(v) if v != "" else math.nan for v in values]
    return "string", values


def column_kinds(sweep: Any) -> dict[str, str]:
    """The Parquet type of each column of ``sweep``'s table (see :func:`_typed`): the fixed columns'
    (:data:`FIXED_KINDS`), each metric's by its kind, each axis's by its values."""
    kinds = {name: kind for name, kind in FIXED_KINDS.items() if name in sweep.columns}
    kinds.update({name: "string" if kind == "text" else "number" for name, kind in sweep.metric_kinds.items()})
    for axis in sweep.axes:
        if axis.sampler is not None and axis.sampler[0] != "choice":
            kinds[axis.name] = "float64"  # drawn from a range (uniform, loguniform)
        else:
            kinds[axis.name] = _kind_of_values(axis.values if axis.sampler is None else axis.sampler[1])
    return kinds


def _kind_of_values(values: Any) -> str:
    """The Parquet type of an axis's values: bool, int64, float64 (numbers, some not whole), or string."""
    if values and all(isinstance(v, bool) for v in values):
        return "bool"
    if values and all(isinstance(v, int) and not isinstance(v, bool) and abs(v) < 2**63 for v in values):
        return "int64"
    if values and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return "float64"
    return "string"


def write_parquet(path: Path, rows: list[dict[str, str]], columns: list[str], meta: dict[str, Any],
                  kinds: dict[str, str] | None = None) -> None:
    """The finished table as Parquet, each column typed as ``kinds`` declares (see :func:`_typed`),
    with the sweep's record in its metadata."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays, fields = [], []
    for name in columns:
        kind, values = _typed([row[name] for row in rows], (kinds or {}).get(name))
        arrays.append(pa.array(values, type=_arrow_type(pa, kind)))
        fields.append(pa.field(name, _arrow_type(pa, kind)))
    schema = pa.schema(fields, metadata={"cosim.sweep": json.dumps(meta, default=str)})
    with written_whole(path) as tmp:
        pq.write_table(pa.Table.from_arrays(arrays, schema=schema), tmp)


def _arrow_type(pa: Any, kind: str) -> Any:
    return pa.bool_() if kind == "bool" else getattr(pa, kind)()


def _offset_of_line(raw: bytes, line: int) -> int:
    """The byte offset in ``raw`` where its 1-based ``line`` starts."""
    offset = 0
    for _ in range(line - 1):
        offset = raw.index(b"\n", offset) + 1
    return offset
