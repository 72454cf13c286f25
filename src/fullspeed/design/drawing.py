"""Writing a figure whatever script its names are in: a scenario or machine
named in Chinese, Japanese or Korean is drawn with a font that has the
glyphs where one is installed, else as the default font's boxes without a
warning a line per glyph; the name stays in the PNG's own text (its Title),
where a reader or a search finds it either way."""
from __future__ import annotations

import functools
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import font_manager  # noqa: E402
from matplotlib.text import Text  # noqa: E402

# fonts with the CJK ideographs, kana and hangul, tried in this order after the
# default font for a glyph it lacks (matplotlib's font fallback, a list of
# families); only the installed ones are named: an absent one is a log line
FALLBACK_FONTS = ("Noto Sans CJK SC", "Noto Sans CJK JP", "Noto Sans CJK TC", "Noto Sans CJK KR",
                  "Source Han Sans SC", "Source Han Sans", "WenQuanYi Zen Hei", "WenQuanYi Micro Hei",
                  "Droid Sans Fallback", "AR PL UMing CN", "Microsoft YaHei", "SimHei", "MS Gothic",
                  "Hiragino Sans", "PingFang SC", "Arial Unicode MS", "Unifont")

# matplotlib's words when no font of the list has a character (matplotlib.backends._backend_agg)
MISSING_GLYPH = r"Glyph \d+ .* missing from font"


@functools.cache
def fallback_fonts() -> tuple[str, ...]:
    """The FALLBACK_FONTS installed here."""
    have = {f.name for f in font_manager.fontManager.ttflist}
    return tuple(f for f in FALLBACK_FONTS if f in have)


def save_figure(fig, path: str | Path, dpi: int, title: str) -> Path:
    """Lay fig out, write it to path (its format by the suffix) with title as
    its Title, close it.
    The text is measured and drawn here (tight_layout, savefig), so the fonts
    and the quiet missing glyphs apply to all of it."""
    rc = {"font.family": [*plt.rcParams["font.family"], *fallback_fonts()]}
    try:
        with warnings.catch_warnings(), plt.rc_context(rc):
            warnings.filterwarnings("ignore", message=MISSING_GLYPH, category=UserWarning)
            for text in fig.findobj(Text):   # made before the fonts above: given them
                text.set_fontfamily(rc["font.family"])
            fig.tight_layout()
            fig.savefig(path, dpi=dpi, metadata={"Title": title})
    finally:
        plt.close(fig)
    return Path(path)
