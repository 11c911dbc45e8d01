"""The contact sheet of a benchmark: every case's input and open renders in one labelled PNG grid,
for a person to check at a glance that the renders look like the objects (colours, lighting, framing)."""

from __future__ import annotations

from pathlib import Path

from spark_bench.data.case import Benchmark
from spark_bench.errors import SparkBenchError


def write_contact_sheet(bench: str | Path, path: str | Path | None = None, thumb: int = 192,
                        columns: int = 4) -> Path:
    """A PNG grid of every case: input | open side by side, labelled with id and category.

    :param bench: the benchmark folder
    :param path: output file (default: the benchmark's :attr:`~spark_bench.data.case.Benchmark.contact_sheet_path`)
    :param thumb: size of each image in pixels
    :param columns: cases per row
    """
    from PIL import Image, ImageDraw, ImageFont

    bench = Benchmark(bench)
    path = Path(path) if path else bench.contact_sheet_path
    ids = bench.complete_case_ids()
    if not ids:
        raise SparkBenchError(f"{bench.folder}: no complete cases for a contact sheet")
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
        case = bench.case(case_id)
        x0, y0 = pad + (k % columns) * cell_w, pad + (k // columns) * cell_h
        for j, picture in enumerate((case.input_image, case.open_image)):
            with Image.open(picture) as image:
                sheet.paste(image.convert("RGB").resize((thumb, thumb), Image.LANCZOS), (x0 + j * thumb, y0))
        category = case.record.get("category", "")
        draw.text((x0 + 2, y0 + thumb + 3), f"{case_id}  {category}  (input | open)", fill=(20, 20, 20), font=font)
    sheet.save(path)
    return path
