"""`appliance logs check|recover`."""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from appliance.logs import LogError, LogSummary, check_log, recover_log

app = typer.Typer(help="Check and recover MCAP field logs.", no_args_is_help=True)

MAX_GAPS_SHOWN = 10


def _time(stamp_ns: int | None) -> str:
    if stamp_ns is None:
        return "-"
    return datetime.fromtimestamp(stamp_ns / 1e9, timezone.utc).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]


def _console() -> Console:
    """Rich's console; 120 columns when the output is not a terminal (pipes, CI logs)."""
    console = Console()
    return console if console.is_terminal else Console(width=120)


def print_summary(summary: LogSummary, console: Console) -> None:
    """The topics table, then duration, frames, gaps and the verdict."""
    table = Table(title=f"{summary.path}  (start {_time(summary.start_ns)} UTC)", title_justify="left")
    for name in ("topic", "schema"):
        table.add_column(name, overflow="fold")
    for name in ("messages", "rate Hz", "first s", "last s"):
        table.add_column(name, justify="right", no_wrap=True, min_width=len(name))

    def rel(stamp_ns):
        return "-" if stamp_ns is None else f"{(stamp_ns - summary.start_ns) / 1e9:.2f}"

    for t in summary.topics.values():
        table.add_row(t.topic, t.schema, str(t.count), f"{t.rate_hz:.1f}" if t.rate_hz else "-",
                      rel(t.first_ns), rel(t.last_ns))
    console.print(table)
    console.print(f"duration {summary.duration_s:.2f} s, {summary.frames} stereo pairs, "
                  f"{summary.size_bytes / 1e6:.1f} MB, metadata: {', '.join(summary.metadata) or 'none'}")
    if summary.gaps:
        console.print(f"{len(summary.gaps)} gap(s) in the frames:")
        for gap in summary.gaps[:MAX_GAPS_SHOWN]:
            console.print(f"  after seq {gap.after_seq} at {_time(gap.start_ns)}: {gap.duration_s:.2f} s, "
                          f"{gap.missing} pair(s) missing")
        if len(summary.gaps) > MAX_GAPS_SHOWN:
            console.print(f"  ... and {len(summary.gaps) - MAX_GAPS_SHOWN} more")
    else:
        console.print("no gaps in the frames")
    if summary.intact:
        console.print("[green]intact[/green]: finished by its writer, with its index")
    else:
        console.print(f"[red]NOT intact[/red]: {summary.problem}")


@app.command("check")
def check(
    files: Annotated[list[Path], typer.Argument(help="MCAP logs (e.g. logs/*.mcap).", show_default=False)],
) -> None:
    """Summarise logs (topics, counts, duration, gaps); exit 1 when one is not intact."""
    console = _console()
    broken = []
    for file in files:
        summary = check_log(file)
        print_summary(summary, console)
        if not summary.intact:
            broken.append(file)
    for file in broken:
        typer.echo(f"{file}: not intact; `appliance logs recover {file}` writes a readable copy", err=True)
    if broken:
        raise typer.Exit(1)


@app.command("recover")
def recover(
    file: Annotated[Path, typer.Argument(help="A log cut short (e.g. by a crash or power loss).",
                                         show_default=False)],
    out: Annotated[Optional[Path], typer.Option("--out", "-o", help="Where to write the copy "
                                                "[default: FILE.recovered.mcap].")] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace OUT if it exists.")] = False,
) -> None:
    """Write a readable, indexed copy of everything whole in a log."""
    out = out or file.with_name(f"{file.stem}.recovered.mcap")
    if out.exists() and not force:
        raise LogError(f"{out}: exists; pass --force to replace it or --out another file")
    before = check_log(file)
    summary = recover_log(file, out)
    console = _console()
    print_summary(summary, console)
    state = "intact" if before.intact else f"not intact: {before.problem}"
    console.print(f"{file} ({state}): {sum(summary.counts.values())} messages, {summary.frames} stereo pairs "
                  f"copied into {out}")
