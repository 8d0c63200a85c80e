"""history.csv: one row per completed step, appended and flushed as the step completes, so a
killed run keeps its history up to the last step."""

from __future__ import annotations

from pathlib import Path

from fsci.io.atomic import write_text


def _cell(v: object) -> str:
    return f"{v:.12g}" if isinstance(v, float) else str(v)


class HistoryFile:
    """``path`` kept equal to the rows of a history list (a list of dicts)."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.keys: list[str] = []
        self.rows = 0

    def rewrite(self, history: list[dict[str, float]]) -> None:
        """Write every row (atomically); the columns are the union of the rows' keys in order
        of appearance."""
        keys: list[str] = []
        for row in history:
            keys += [k for k in row if k not in keys]
        lines = [",".join(keys)] + [",".join(_cell(row.get(k, "")) for k in keys) for row in history]
        write_text(self.path, "\n".join(lines) + "\n" if history else "")
        self.keys, self.rows = keys, len(history)

    def sync(self, history: list[dict[str, float]]) -> None:
        """Append the rows added since the last call (rewrite when a new column appeared or
        rows were taken back); flushed before returning."""
        new = history[self.rows:]
        if self.rows > len(history) or self.rows == 0 or any(k not in self.keys for row in new for k in row):
            self.rewrite(history)
            return
        with open(self.path, "a", encoding="utf-8") as fh:
            for row in new:
                fh.write(",".join(_cell(row.get(k, "")) for k in self.keys) + "\n")
            fh.flush()
        self.rows = len(history)
