"""`mett figures --dpi N --format png|pdf|svg`: files of the format asked for, valid, at that
resolution, the same bytes on every run; bad values refused in one line before anything is
written."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import matplotlib

matplotlib.use("Agg")

import pytest

from mett import cli, gallery

CHEAP = ["separation_f", "potential_slice"]  # no simulation behind them
W, H = gallery.STYLE["figure.figsize"]  # inches


def _pdf_pages(data: bytes) -> int:
    # matplotlib writes each page object as a plain dictionary "/Type /Page" (the catalogue
    # of pages is "/Type /Pages")
    return len(re.findall(rb"/Type\s*/Page(?![a-zA-Z])", data))


def test_pdf_is_a_valid_one_page_document_of_the_figure_size(tmp_path):
    (path,) = gallery.generate(tmp_path, names=CHEAP[:1], animation=False, format="pdf", dpi=300)
    assert path.name == "separation_f.pdf"
    data = path.read_bytes()
    assert data.startswith(b"%PDF-1.") and data.rstrip().endswith(b"%%EOF")
    assert _pdf_pages(data) == 1
    (box,) = re.findall(rb"/MediaBox\s*\[\s*0 0 ([\d.]+) ([\d.]+)\s*\]", data)
    # 72 PDF points per inch, the figure's size
    assert (float(box[0]), float(box[1])) == pytest.approx((72 * W, 72 * H), abs=0.01)
    assert b"/CreationDate" not in data  # reproducible: no date in the file


def test_svg_is_well_formed_and_of_the_figure_size(tmp_path):
    (path,) = gallery.generate(tmp_path, names=CHEAP[:1], animation=False, format="svg")
    root = ET.parse(path).getroot()
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    assert float(root.get("width").removesuffix("pt")) == pytest.approx(72 * W, abs=0.01)
    assert float(root.get("height").removesuffix("pt")) == pytest.approx(72 * H, abs=0.01)
    assert b"<dc:date>" not in path.read_bytes()


@pytest.mark.parametrize("fmt", gallery.FORMATS)
def test_every_format_is_the_same_bytes_on_a_second_run(tmp_path, fmt):
    a = gallery.generate(tmp_path / "a", names=CHEAP, animation=False, format=fmt, dpi=50)
    b = gallery.generate(tmp_path / "b", names=CHEAP, animation=False, format=fmt, dpi=50)
    assert [p.name for p in a] == [f"{n}.{fmt}" for n in CHEAP]
    for p, q in zip(a, b, strict=True):
        assert p.read_bytes() == q.read_bytes(), p.name


@pytest.mark.parametrize("dpi", [72, 300])
def test_png_dpi_reaches_the_pixels_and_the_metadata(tmp_path, dpi):
    from PIL import Image

    (path,) = gallery.generate(tmp_path, names=CHEAP[:1], animation=False, dpi=dpi)
    with Image.open(path) as im:
        assert im.format == "PNG"
        assert im.size == pytest.approx((W * dpi, H * dpi), abs=1)  # whole pixels
        # pHYs stores pixels per metre (an integer): dpi to within that rounding
        assert im.info["dpi"] == pytest.approx((dpi, dpi), abs=0.02)


@pytest.mark.parametrize(
    ("kw", "error", "match"),
    [
        ({"format": "jpg"}, ValueError, "format must be one of png, pdf, svg"),
        ({"format": "PDF"}, ValueError, "format"),
        ({"dpi": 0}, ValueError, "dpi must be between 10 and 2400"),
        ({"dpi": 5000}, ValueError, "dpi"),
        ({"dpi": 300.0}, TypeError, "dpi must be an integer"),
        ({"dpi": True}, TypeError, "dpi"),
    ],
)
def test_bad_format_or_dpi_is_refused_before_anything_is_written(tmp_path, kw, error, match):
    out = tmp_path / "out"
    with pytest.raises(error, match=match):
        gallery.generate(out, names=CHEAP[:1], animation=False, **kw)
    assert not out.exists()


def test_file_names_cover_every_format():
    names = set(gallery.file_names())
    for fmt in gallery.FORMATS:
        assert {f"{n}.{fmt}" for n in gallery.FIGURES} <= names
    assert "deforming_potential.gif" in names and gallery.INDEX_NAME in names


def test_the_index_links_a_pdf_and_shows_an_svg(tmp_path):
    text = gallery.index_markdown([tmp_path / "separation_f.pdf", tmp_path / "subgroups.svg"])
    assert f"[{gallery.FIGURES['separation_f'][0]} (PDF)](separation_f.pdf)" in text
    assert f"![{gallery.FIGURES['subgroups'][0]}](subgroups.svg)" in text


# --- the command ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--format", "jpg"], "--format"),
        (["--format", ""], "--format"),
        (["--dpi", "0"], "--dpi"),
        (["--dpi", "3e2"], "--dpi"),
        (["--dpi", "-300"], "--dpi"),
        (["--dpi", "2401"], "--dpi"),
    ],
)
def test_cli_refuses_a_bad_format_or_dpi_in_one_line(tmp_path, capsys, args, match):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        cli.main(["figures", "--out", str(out), *args])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("mett: error:") and match in err
    assert not out.exists()


def test_cli_passes_dpi_and_format_to_the_gallery(tmp_path, capsys, monkeypatch):
    seen = {}

    def fake_generate(out_dir, **kw):
        seen.update(kw)
        out_dir.mkdir(parents=True, exist_ok=True)
        path = out_dir / f"separation_f.{kw['format']}"
        path.write_bytes(b"%PDF-1.4")
        return [path]

    monkeypatch.setattr(gallery, "generate", fake_generate)
    assert cli.main(["figures", "--out", str(tmp_path), "--dpi", "300", "--format", "pdf"]) == 0
    assert seen["dpi"] == 300 and seen["format"] == "pdf"
    index = (tmp_path / gallery.INDEX_NAME).read_text()
    assert "(separation_f.pdf)" in index
    seen.clear()
    assert cli.main(["figures", "--out", str(tmp_path)]) == 0  # the README's main job
    assert seen["dpi"] == gallery.DEFAULT_DPI and seen["format"] == "png"


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["pdf"])
def test_every_gallery_figure_is_written_in_the_vector_formats(tmp_path, fmt):
    paths = gallery.generate(tmp_path, animation=False, format=fmt, dpi=300)
    assert [p.name for p in paths] == [f"{n}.{fmt}" for n in gallery.FIGURES]
    for p in paths:
        data = p.read_bytes()
        if fmt == "pdf":
            assert data.startswith(b"%PDF-1.") and _pdf_pages(data) == 1, p.name
        else:
            assert ET.parse(p).getroot().tag == "{http://www.w3.org/2000/svg}svg", p.name
