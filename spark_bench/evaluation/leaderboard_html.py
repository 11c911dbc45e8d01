"""The HTML leaderboard page: tables with the paper's colours, bar charts, and a per-case gallery.

The page is one file; its images (PNG, and for runs with ``eval --rl`` one GIF episode of the RL policy per
case) go into a folder beside it (``<name>_files/``) and are linked
with relative paths, so the page and its folder can be copied anywhere together.
"""

from __future__ import annotations

import html
import shutil
import textwrap
from pathlib import Path

from spark_bench.data.case import BenchmarkCase
from spark_bench.evaluation.board import (
    HEADERS,
    PALETTE,
    PART_CLASS_NOTE,
    Leaderboard,
    Table,
    fmt_value,
    is_number,
)

RENDER_SIZE = 192

_CSS = "\n".join([
    "body { font-family: system-ui, sans-serif; margin: 24px; color: #222; }",
    "table { border-collapse: collapse; margin: 8px 0 24px; }",
    "th, td { border-bottom: 1px solid #ccc; padding: 4px 10px; text-align: right; }",
    "th:first-child, td:first-child, th:nth-child(2), td:nth-child(2) { text-align: left; }",
    f"td.best {{ background: rgb{PALETTE['Palette5']}; font-weight: bold; }}",
    f"td.second {{ background: rgb{PALETTE['Palette4']}; }}",
    ".gallery td { text-align: center; vertical-align: top; font-size: 12px; }",
    f".gallery img {{ width: {RENDER_SIZE}px; height: {RENDER_SIZE}px; border: 1px solid #ddd; }}",
    ".gallery img.episode { width: 240px; height: auto; }",
    ".charts img { max-width: 100%; }",
    ".na { color: #888; }",
])


def html_escape(text: str) -> str:
    return html.escape(str(text), quote=True)


def copy_file(src: Path, dst: Path) -> bool:
    """Copy ``src`` to ``dst`` when it exists; whether it did."""
    if Path(src).is_file():
        shutil.copyfile(src, dst)
        return True
    return False


def _table_html(table: Table) -> str:
    ranks = table.ranks()
    head = "".join(f"<th>{html_escape(h)}</th>" for h in
                   ["Method", "Regime", *[HEADERS[m] for m in table.metrics], *table.count_headers()])
    lines = [f"<table class='metrics' id='table-{table.key}'><tr>{head}</tr>"]
    for i, e in enumerate(table.entries):
        cells = []
        for m in table.metrics:
            value = e.metrics.get(m)
            rank = ranks.get((i, m))
            css = "best" if rank == 1 else "second" if rank == 2 else ("na" if not is_number(value) else "")
            cells.append(f"<td class='{css}'>{fmt_value(value)}</td>")
        counts = "".join(f"<td>{html_escape(c)}</td>" for c in table.count_cells(e))
        lines.append(f"<tr><td>{html_escape(e.name)}</td><td>{html_escape(e.regime)}</td>{''.join(cells)}"
                     f"{counts}</tr>")
    lines.append("</table>")
    return "\n".join(lines)


def bar_chart(table: Table, path: Path) -> Path | None:
    """One horizontal bar chart per metric of ``table`` (n/a values left out), as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    metrics = [m for m in table.metrics if any(is_number(e.metrics.get(m)) for e in table.entries)]
    if not metrics:
        return None
    # long labels (ours' backends) wrapped onto lines of their own, so the bars keep the width
    names = ["\n".join(textwrap.wrap(e.name.replace(",", ", "), 34)) for e in table.entries]
    lines = max(name.count("\n") + 1 for name in names)
    fig, axes = plt.subplots(1, len(metrics), figsize=(2.2 + 2.6 * len(metrics), (0.25 + 0.17 * lines) * len(names) + 1.0),
                             squeeze=False)
    for ax, metric in zip(axes[0], metrics):
        values = [e.metrics.get(metric) if is_number(e.metrics.get(metric)) else 0.0 for e in table.entries]
        colors = ["#b8a8cf" if e.ranked else "#cccccc" for e in table.entries]
        ax.barh(range(len(names)), values, color=colors)
        ax.set_yticks(range(len(names)), names if ax is axes[0][0] else [""] * len(names), fontsize=8)
        ax.invert_yaxis()
        ax.set_title(HEADERS[metric], fontsize=9)  # its arrow says which way is better
        for k, e in enumerate(table.entries):
            if not is_number(e.metrics.get(metric)):
                ax.text(0, k, " n/a", va="center", fontsize=7, color="#888")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


STATES = ("rest", "open")


def _render_cells(folder: str | Path | None, camera: dict, stem: Path) -> list[str]:
    """One cell per state of :data:`STATES`: the object folder rendered into ``<stem>_<state>.png``
    (kept when already there), loaded once for all of them."""
    from spark_bench.evaluation.render import load_for_render, render_state

    if not folder:
        return ["<td class='na'>no prediction</td>"] * len(STATES)
    asset = None
    cells = []
    for state in STATES:
        target = stem.with_name(f"{stem.name}_{state}.png")
        try:
            if not target.is_file():
                if asset is None:
                    asset = load_for_render(Path(folder))
                render_state(asset, camera, state, RENDER_SIZE).save(target)
        except Exception as exc:  # a broken prediction must not break the page
            cells.append(f"<td class='na'>cannot render: {html_escape(type(exc).__name__)}</td>")
            continue
        cells.append(f"<td><img src='{html_escape(target.parent.name + '/' + target.name)}' alt='{state}'></td>")
    return cells


def _rl_of(row: dict) -> dict:
    return (row.get("checks") or {}).get("rl") or {}


def rl_video_cell(row: dict, stem: Path) -> str:
    """The case's RL episode (``eval --rl`` keeps one per case: the fine-tuned policy on the first
    ground-truth drawer or door it was run on), copied beside the page, with the joint's outcome."""
    rl = _rl_of(row)
    for name, joint in (rl.get("joints") or {}).items():
        video = joint.get("video")
        if not video:
            continue
        target = stem.with_name(f"{stem.name}{Path(video).suffix}")
        if not copy_file(Path(video), target):
            return f"<td class='na'>episode video missing: {html_escape(video)}</td>"
        outcome = "opened" if joint.get("success") else "not opened"
        if joint.get("success") not in (None, 0.0, 1.0):
            outcome = f"opened in {100 * joint['success']:.0f}% of episodes"
        return (f"<td><img src='{html_escape(target.parent.name + '/' + target.name)}' alt='RL episode' class='episode'>"
                f"<br>{html_escape(name)}: {html_escape(outcome)}</td>")
    if rl.get("error"):
        return f"<td class='na'>RL stage failed: {html_escape(rl['error'][:120])}</td>"
    if rl and rl.get("success_rate") is None:
        left_out = rl.get("left_out") or {}
        if left_out:  # drawers and doors nobody can open: say why, not that there are none
            name, reason = next(iter(left_out.items()))
            return f"<td class='na'>left out: {html_escape(name)}: {html_escape(reason[:120])}</td>"
        return "<td class='na'>no drawer or door</td>"
    why = next((j.get("why") for j in (rl.get("joints") or {}).values() if j.get("why")), None)
    return f"<td class='na'>{html_escape(why or 'no RL episode')}</td>"


def _gallery(board: Leaderboard, assets: Path, max_cases: int) -> str:
    from spark_bench.evaluation.render import read_camera

    by_case: dict[str, dict[int, dict]] = {}
    case_dirs: dict[str, str] = {}
    for k, entry in enumerate(board.entries):
        for row in entry.rows:
            by_case.setdefault(row["case_id"], {})[k] = row
            case_dirs.setdefault(row["case_id"], row["case_dir"])
    rl_entries = {k for k, entry in enumerate(board.entries) if any(_rl_of(r) for r in entry.rows)}
    lines = ["<table class='gallery'>"]
    for n, case_id in enumerate(sorted(by_case)[:max_cases]):
        case = BenchmarkCase(Path(case_dirs[case_id]))
        camera = read_camera(case.camera_path)
        stem = f"case{n:03d}"
        image = assets / f"{stem}_input.png"
        has_input = copy_file(case.input_image, image)
        cells = [f"<td><b>{html_escape(case_id)}</b><br>"
                 + (f"<img src='{assets.name}/{image.name}' alt='input'>" if has_input else "no input image")
                 + "<br>input</td>"]
        header = ["<th>case</th>", *[f"<th>ground truth<br>{s}</th>" for s in STATES]]
        cells += _render_cells(case.gt_dir, camera, assets / f"{stem}_gt")
        for k, entry in enumerate(board.entries):
            header += [f"<th>{html_escape(entry.name)}<br>{s}</th>" for s in STATES]
            if k in rl_entries:
                header.append(f"<th>{html_escape(entry.name)}<br>RL episode</th>")
            row = by_case[case_id].get(k)
            if row is None or row["status"] != "ok":
                why = "not run" if row is None else f"failed: {row['stage']}"
                cells += [f"<td class='na'>{html_escape(why)}</td>"] * (len(STATES) + (k in rl_entries))
                continue
            cells += _render_cells(row["prediction_dir"], camera, assets / f"{stem}_m{k}")
            if k in rl_entries:
                cells.append(rl_video_cell(row, assets / f"{stem}_m{k}_rl"))
        if n == 0:
            lines.append("<tr>" + "".join(header) + "</tr>")
        lines.append("<tr>" + "".join(cells) + "</tr>")
    lines.append("</table>")
    return "\n".join(lines)


def to_html(board: Leaderboard, out: Path, per_category: bool = False, max_cases: int = 24,
            per_part_class: bool = False) -> str:
    """The page's HTML; its images are written into ``<out stem>_files/`` beside ``out``.

    :param board: the leaderboard
    :param out: the HTML file the text will be written to
    :param per_category: add per-category tables
    :param max_cases: cases shown in the gallery
    :param per_part_class: add one articulation table (and chart) per GAPartNet part class
    """
    out = Path(out)
    assets = out.parent / f"{out.stem}_files"
    assets.mkdir(parents=True, exist_ok=True)
    parts = ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
             f"<title>spark-bench leaderboard: {html_escape(board.bench)}</title>",
             f"<style>{_CSS}</style></head><body>",
             f"<h1>spark-bench leaderboard: {html_escape(board.bench)}</h1>",
             "<p>Best of each column <span style='background:rgb{}'>highlighted</span>, second best "
             "<span style='background:rgb{}'>lighter</span>; reference rows (regime <i>ground truth</i>) are "
             "not ranked; n/a: not measured or not meaningful. {}</p>".format(
                 PALETTE["Palette5"], PALETTE["Palette4"], html_escape(" ".join(board.notes())))]
    charts = []
    for table in board.tables():
        parts += [f"<h2>{html_escape(table.title)}</h2>", _table_html(table)]
        chart = bar_chart(table, assets / f"chart_{table.key}.png")
        if chart is not None:
            charts.append(f"<img src='{assets.name}/{chart.name}' alt='{html_escape(table.title)} chart'>")
    if per_category:
        for category, entries in board.categories.items():
            parts.append(f"<h2>{html_escape(category)}</h2>")
            for table in board.tables(entries):
                parts += [f"<h3>{html_escape(table.title)}</h3>", _table_html(table)]
    if per_part_class:
        for table in board.part_class_tables():
            parts += [f"<h2>{html_escape(table.title)}</h2>", _table_html(table)]
            chart = bar_chart(table, assets / f"chart_{table.key}.png")
            if chart is not None:
                charts.append(f"<img src='{assets.name}/{chart.name}' alt='{html_escape(table.title)} chart'>")
        parts.append(f"<p>{html_escape(PART_CLASS_NOTE)}</p>")
    parts += ["<h2>Charts</h2>", "<div class='charts'>", *charts, "</div>",
              "<h2>Cases</h2>", _gallery(board, assets, max_cases), "</body></html>"]
    return "\n".join(parts) + "\n"
