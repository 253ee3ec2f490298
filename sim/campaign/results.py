"""A campaign's results file: one row a task, written as rows arrive, read
back to resume.

CSV (``.csv``): the first line is ``# roboray-campaign {JSON}``, the
campaign's kind, parameters and column types, so that a resume can check
it continues the same campaign; then a header line of the column names,
then one line a row, appended and flushed as each task ends (in the order
they end). pandas reads it with ``read_csv(path, comment="#")``, polars with
``read_csv(path, comment_prefix="#")``, the csv module once the first line
is skipped. Floats are written as ``repr`` writes them, which reads back
to the same double, so a resumed campaign's rows are bit for bit those of
an uninterrupted one. When the campaign is complete the file is rewritten
in index order (a new file renamed over the old one): a campaign run at
once and one resumed three times end as the same bytes.

A line cut short by a crash (no newline at its end) is dropped with a
notice and its task is run again; a line that does not parse anywhere
else means the file is not this campaign's, and nothing is touched.

Parquet (``.parquet``, with pyarrow): a Parquet file is readable only once
its footer is written, so the rows go to a CSV journal beside it
(``FILE.parquet.part``, the format above) as they arrive, and the Parquet
file, its campaign header in the file's key-value metadata, is written
from them when the campaign is complete; the journal is then removed.
"""

from __future__ import annotations

import csv
import io
import json
import os
from typing import Callable, Sequence

MAGIC = "# roboray-campaign "
#: Column types a row may hold; None (an empty field) is allowed in each.
TYPES = ("int", "float", "bool", "str")
INDEX = "run"


class ResultsError(ValueError):
    """A results file this campaign cannot use; one line for the user."""


def header(kind: str, params: dict, columns: Sequence[tuple[str, str]]) -> dict:
    """The campaign's identity as the file's first line holds it."""
    for name, kind_ in columns:
        if kind_ not in TYPES:
            raise ValueError("column %r: type must be one of %s, got %r" % (name, TYPES, kind_))
    return {"kind": kind, "params": params, "columns": [[INDEX, "int"]] + [list(c) for c in columns]}


def format_value(value, kind: str) -> str:
    if value is None:
        return ""
    if kind == "float":
        return repr(float(value))
    if kind == "int":
        return str(int(value))
    if kind == "bool":
        return "true" if value else "false"
    text = str(value)
    if "\n" in text or "\r" in text:
        # a row is one line: that is how a resume finds a torn one
        raise ValueError("a row's string %r has a line break" % text[:40])
    return text


def parse_value(text: str, kind: str):
    if text == "":
        return None
    if kind == "float":
        return float(text)
    if kind == "int":
        return int(text)
    if kind == "bool":
        if text not in ("true", "false"):
            raise ValueError("%r is not true or false" % text)
        return text == "true"
    return text


def check_row(row: dict, columns: Sequence[Sequence[str]]) -> None:
    """A task's row has exactly the campaign's columns (the index aside)."""
    names = [c[0] for c in columns if c[0] != INDEX]
    missing = [n for n in names if n not in row]
    extra = [k for k in row if k not in names]
    if missing or extra:
        raise ValueError("a task's row does not match the campaign's columns: missing %s, unexpected %s"
                         % (missing or "none", extra or "none"))


class ResultsFile:
    """Rows of one campaign in ``path`` (``.csv`` or ``.parquet``).

    ``open(total)`` reads what a previous run left (checking it is the same
    campaign) and returns those rows by index; ``append(index, row)``
    writes one row at once; ``finish(rows)`` writes the complete file.
    """

    def __init__(self, path: str, head: dict, notice: Callable[[str], None] = lambda line: None) -> None:
        self.path = path
        self.head = head
        self.columns = head["columns"]
        self.notice = notice
        suffix = os.path.splitext(path)[1].lower()
        if suffix not in (".csv", ".parquet"):
            raise ResultsError("%s: a results file ends in .csv or .parquet" % path)
        self.parquet = suffix == ".parquet"
        if self.parquet:
            try:
                import pyarrow  # noqa: F401
            except ImportError:
                raise ResultsError("%s: Parquet needs pyarrow: pip install 'roboray[parquet]' (or write .csv)" % path)
        self.journal = path + ".part" if self.parquet else path
        self._file = None

    # ------------------------------------------------------------ reading
    def open(self, total: int) -> dict:
        """Rows already present, by index; the journal opened for appending."""
        rows: dict = {}
        if self.parquet and os.path.exists(self.path) and not os.path.exists(self.journal):
            rows = self._read_parquet(total)
        elif os.path.exists(self.journal) and os.path.getsize(self.journal) > 0:
            rows = self._read_csv(total)
        else:
            self._start_csv()
        if self._file is None:
            self._file = open(self.journal, "a", newline="")
            self._lock()
        return rows

    def _lock(self) -> None:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not on POSIX
            return
        try:
            fcntl.flock(self._file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._file.close()
            self._file = None
            raise ResultsError("%s is being written by another campaign right now" % self.journal)

    def _start_csv(self) -> None:
        with open(self.journal, "w", newline="") as f:
            f.write(self._preamble())
            f.flush()
            os.fsync(f.fileno())

    def _preamble(self) -> str:
        out = io.StringIO()
        out.write(MAGIC + json.dumps(self.head, sort_keys=True, separators=(",", ":")) + "\n")
        csv.writer(out, lineterminator="\n").writerow([c[0] for c in self.columns])
        return out.getvalue()

    def _same_campaign(self, found: dict, where: str) -> None:
        if found == self.head:
            return
        if found.get("kind") != self.head["kind"]:
            raise ResultsError("%s holds a %s campaign, not %s: give another results file or remove it"
                               % (where, found.get("kind"), self.head["kind"]))
        theirs, ours = found.get("params", {}), self.head["params"]
        differ = sorted(k for k in set(theirs) | set(ours) if theirs.get(k) != ours.get(k))
        if differ:
            k = differ[0]
            raise ResultsError("%s holds another %s campaign (%s %s there, %s here): give another results file "
                               "or remove it" % (where, self.head["kind"], k, json.dumps(theirs.get(k)),
                                                 json.dumps(ours.get(k))))
        raise ResultsError("%s holds this campaign with other columns (written by another version): give another "
                           "results file or remove it" % where)

    def _read_csv(self, total: int) -> dict:
        with open(self.journal, "rb") as f:
            data = f.read()
        where = self.journal
        first, _, rest = data.partition(b"\n")
        try:
            text = first.decode()
            if not text.startswith(MAGIC):
                raise ValueError
            found = json.loads(text[len(MAGIC):])
        except ValueError:
            raise ResultsError("%s is not a roboray campaign's results file (no '%s' first line): give another "
                               "results file" % (where, MAGIC.strip()))
        self._same_campaign(found, where)
        names_line, _, body = rest.partition(b"\n")
        if names_line.decode(errors="replace") != ",".join(c[0] for c in self.columns):
            raise ResultsError("%s: its column line is not this campaign's" % where)
        good = len(first) + 1 + len(names_line) + 1
        rows: dict = {}
        lines = body.split(b"\n")
        torn = lines.pop()   # after the last newline: empty unless the last write was cut short
        for number, line in enumerate(lines, start=3):
            try:
                index, row = self._parse(line.decode())
            except ValueError as exc:
                raise ResultsError("%s line %d is not a row of this campaign (%s): nothing was changed"
                                   % (where, number, exc))
            if not 0 <= index < total:
                raise ResultsError("%s line %d: run %d is outside this campaign's 0..%d" % (where, number, index,
                                                                                         total - 1))
            rows.setdefault(index, row)   # a row written twice is one row
            good += len(line) + 1
        if torn:
            self.notice("%s: its last line was cut short (the campaign stopped mid-write): dropped, that run "
                        "will be redone" % where)
            with open(self.journal, "r+b") as f:
                f.truncate(good)
        return rows

    def _parse(self, line: str) -> tuple[int, dict]:
        fields = next(csv.reader([line]))
        if len(fields) != len(self.columns):
            raise ValueError("%d fields, %d columns" % (len(fields), len(self.columns)))
        row = {}
        for (name, kind), text in zip(self.columns, fields):
            row[name] = parse_value(text, kind)
        index = row.pop(INDEX)
        if index is None:
            raise ValueError("no run index")
        return index, row

    def _read_parquet(self, total: int) -> dict:
        import pyarrow.parquet as pq

        try:
            table = pq.read_table(self.path)
        except Exception as exc:  # noqa: BLE001 - pyarrow's errors are many
            raise ResultsError("%s is not a readable Parquet file (%s): give another results file or remove it"
                               % (self.path, str(exc).splitlines()[0] if str(exc) else type(exc).__name__))
        meta = table.schema.metadata or {}
        raw = meta.get(b"roboray_campaign")
        if raw is None:
            raise ResultsError("%s is not a roboray campaign's results file: give another results file" % self.path)
        self._same_campaign(json.loads(raw), self.path)
        rows = {}
        for rec in table.to_pylist():
            index = rec.pop(INDEX)
            if not 0 <= index < total:
                raise ResultsError("%s: run %d is outside this campaign's 0..%d" % (self.path, index, total - 1))
            rows.setdefault(index, rec)
        # rows are complete: the journal restarts from them should a run be missing
        with open(self.journal, "w", newline="") as f:
            f.write(self._preamble())
            for index in sorted(rows):
                f.write(self._line(index, rows[index]))
        return rows

    # ------------------------------------------------------------ writing
    def _line(self, index: int, row: dict) -> str:
        out = io.StringIO()
        values = dict(row)
        values[INDEX] = index
        csv.writer(out, lineterminator="\n").writerow([format_value(values[name], kind)
                                                       for name, kind in self.columns])
        return out.getvalue()

    def append(self, index: int, row: dict) -> None:
        """One row, whole, on disk before the next task's."""
        # one write of the whole line: a crash leaves at most one torn line
        self._file.write(self._line(index, row))
        self._file.flush()

    def finish(self, rows: dict) -> None:
        """The complete file, in index order, replacing the journal."""
        self.close()
        if self.parquet:
            self._write_parquet(rows)
            os.remove(self.journal)
            return
        tmp = self.path + ".tmp"
        with open(tmp, "w", newline="") as f:
            f.write(self._preamble())
            for index in sorted(rows):
                f.write(self._line(index, rows[index]))
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path)

    def _write_parquet(self, rows: dict) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        kinds = {"int": pa.int64(), "float": pa.float64(), "bool": pa.bool_(), "str": pa.string()}
        schema = pa.schema([(name, kinds[kind]) for name, kind in self.columns],
                           metadata={b"roboray_campaign": json.dumps(self.head, sort_keys=True).encode()})
        order = sorted(rows)
        data = {name: [index if name == INDEX else rows[index][name] for index in order] for name, _ in self.columns}
        tmp = self.path + ".tmp"
        pq.write_table(pa.table(data, schema=schema), tmp)
        os.replace(tmp, self.path)

    def close(self) -> None:
        f, self._file = self._file, None
        if f is not None:
            f.close()


def read_rows(path: str) -> tuple[dict, list[dict]]:
    """A finished results file's header and rows in index order (each with
    its ``run``), through the csv module or pyarrow: what a test or a
    script without pandas uses."""
    if path.lower().endswith(".parquet"):
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        head = json.loads(table.schema.metadata[b"roboray_campaign"])
        return head, table.to_pylist()
    with open(path, newline="") as f:
        first = f.readline()
        if not first.startswith(MAGIC):
            raise ResultsError("%s is not a roboray campaign's results file" % path)
        head = json.loads(first[len(MAGIC):])
        kinds = dict(head["columns"])
        out = []
        for rec in csv.DictReader(f):
            out.append({k: parse_value(v, kinds[k]) for k, v in rec.items()})
    return head, out


def summary_path(results: str) -> str:
    """Where a campaign's summary JSON goes beside its results file."""
    return os.path.splitext(results)[0] + ".summary.json"
