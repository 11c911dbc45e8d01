"""The contact sheet of a benchmark: every case's input and open renders in one labelled PNG grid,
for a person to check at a glance that the renders look like the objects (colours, lighting, framing)."""

from __future__ import annotations

from pathlib import Path

from spark_bench.data.prepare import CASES_DIR, CONTACT_SHEET, complete_cases, read_case
from spark_bench.errors import SparkBenchError


def write_contact_sheet(bench: str | Path, path: str | Path | None = None, thumb: int = 192,
                        columns: int = 4) -> Path:
    """A PNG grid of every case: input | open side by side, labelled with id and category.

    :param bench: the benchmark folder
    :param path: output file (default ``BENCH/contact_sheet.png``)
    :param thumb: size of each image in pixels
    :param columns: cases per row
    """
    from PIL import Image, ImageDraw, ImageFont

    bench = Path(bench)
    path = Path(path) if path else bench / CONTACT_SHEET
    ids = complete_cases(bench)
    if not ids:
        raise SparkBenchError(f"{bench}: no complete cases for a contact sheet")
    label_h, pad = 20, 6
    columns = max(1, min(columns, len(ids)))
    rows = -(-len(ids) // columns)
    cell_w, cell_h = 2 * thumb + pad, thumb + label_h + pad
    sheet = Image.new("RGB", (columns * cell_w + pad, rows * cell_h + pad), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    try:
        font = ImageFont.load_default(size=13)
    except TypeError:  # Pillow < 10.1 has only the bitmap font
        font = ImageFont.load_default()
    for k, case_id in enumerate(ids):
        case_dir = bench / CASES_DIR / case_id
        x0, y0 = pad + (k % columns) * cell_w, pad + (k // columns) * cell_h
        for j, stem in enumerate(("input", "open")):
            with Image.open(case_dir / f"{stem}.png") as image:
                sheet.paste(image.convert("RGB").resize((thumb, thumb), Image.LANCZOS), (x0 + j * thumb, y0))
        category = read_case(case_dir).get("category", "")
        draw.text((x0 + 2, y0 + thumb + 3), f"{case_id}  {category}  (input | open)", fill=(20, 20, 20), font=font)
    sheet.save(path)
    return path
