"""The report page: one HTML file with plotly.js, the page's script and the data inside.

plotly.js comes from the plotly wheel (plotly/package_data/plotly.min.js) and is
inlined, so the page needs no network at view time. The numbers travel as one
gzip-compressed binary block (base64 in a script element), unpacked in the page
by the browser's DecompressionStream into typed arrays: a third of the size of
JSON text and parsed in milliseconds. The page's own script is report.js, next
to this module.
"""
from __future__ import annotations

import base64
import html
import json
import zlib
from importlib import resources
from pathlib import Path

import numpy as np

_ALIGN = 8
GZIP_LEVEL = 1  # level 6 made the page 1 % smaller for twice the time (g1_lhchips4)


class Blob:
    """Arrays laid end to end (8-byte aligned) with a table saying where each one lies."""

    def __init__(self):
        self._parts: list[bytes] = []
        self._size = 0
        self.table: dict[str, list] = {}

    def add(self, name: str, array: np.ndarray, dtype: str) -> None:
        a = np.ascontiguousarray(array, dtype=dtype)
        pad = -self._size % _ALIGN
        if pad:
            self._parts.append(b"\0" * pad)
            self._size += pad
        self.table[name] = [np.dtype(dtype).name, self._size, int(a.size), list(a.shape)]
        data = a.tobytes()
        self._parts.append(data)
        self._size += len(data)

    def add_text(self, name: str, lines: list[str]) -> None:
        self.add(name, np.frombuffer("\n".join(lines).encode("utf-8"), dtype=np.uint8), "u1")

    def encoded(self) -> str:
        """gzip (what DecompressionStream("gzip") reads), then base64."""
        comp = zlib.compressobj(GZIP_LEVEL, zlib.DEFLATED, 31)
        raw = comp.compress(b"".join(self._parts)) + comp.flush()
        return base64.b64encode(raw).decode("ascii")


def _plotly_js() -> str:
    return resources.files("plotly").joinpath("package_data", "plotly.min.js").read_text(encoding="utf-8")


def _script(text: str) -> str:
    # a literal "</script" inside would end the element early
    return text.replace("</script", "<\\/script")


def write_page(out: str | Path, title: str, info: dict, blob: Blob) -> Path:
    """Write the page: `info` (JSON-able: what the script shows and how to read the blob)."""
    out = Path(out)
    own = resources.files("machine.report")
    css = own.joinpath("report.css").read_text(encoding="utf-8")
    script = own.joinpath("report.js").read_text(encoding="utf-8")
    # "<" only occurs inside JSON strings, where \u003c reads the same and cannot close the element
    info_json = json.dumps(dict(info, arrays=blob.table)).replace("<", "\\u003c")
    with open(out, "w", encoding="utf-8") as fh:
        fh.write(f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
                 f"<title>{html.escape(title)}</title>\n<style>{css}</style>\n")
        fh.write("<script>")
        fh.write(_script(_plotly_js()))
        fh.write("</script>\n</head><body>\n")
        fh.write(f"<script type=\"application/json\" id=\"vcnc-info\">{info_json}</script>\n")
        fh.write("<script type=\"application/octet-stream\" id=\"vcnc-blob\">")
        fh.write(blob.encoded())
        fh.write("</script>\n")
        fh.write(f"<script>{_script(script)}</script>\n</body></html>\n")
    return out
