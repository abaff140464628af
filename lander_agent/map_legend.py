"""A legend under the traverse map's picture: a swatch and the name of each class, so ``map.png`` reads alone.

The map is drawn without an imaging library (importing one cost the lander 0.7 s at its first map), so the names
are drawn from a small bitmap font of the letters they use, five pixels wide and seven high.
"""

from __future__ import annotations

import numpy as np

GLYPHS = {
    "a": ("     ", "     ", " ### ", "    #", " ####", "#   #", " ####"),
    "b": ("#    ", "#    ", "#### ", "#   #", "#   #", "#   #", "#### "),
    "c": ("     ", "     ", " ####", "#    ", "#    ", "#    ", " ####"),
    "e": ("     ", "     ", " ### ", "#   #", "#####", "#    ", " ####"),
    "f": ("  ## ", " #   ", "#### ", " #   ", " #   ", " #   ", " #   "),
    "k": ("#    ", "#    ", "#  # ", "# #  ", "##   ", "# #  ", "#  # "),
    "l": (" #   ", " #   ", " #   ", " #   ", " #   ", " #   ", "  ## "),
    "n": ("     ", "     ", "#### ", "#   #", "#   #", "#   #", "#   #"),
    "o": ("     ", "     ", " ### ", "#   #", "#   #", "#   #", " ### "),
    "r": ("     ", "     ", "# ## ", "##   ", "#    ", "#    ", "#    "),
    "s": ("     ", "     ", " ####", "#    ", " ### ", "    #", "#### "),
    "t": (" #   ", " #   ", "#### ", " #   ", " #   ", " #   ", "  ## "),
    "u": ("     ", "     ", "#   #", "#   #", "#   #", "#   #", " ####"),
    "v": ("     ", "     ", "#   #", "#   #", "#   #", " # # ", "  #  "),
    "w": ("     ", "     ", "#   #", "#   #", "# # #", "# # #", " # # "),
    " ": ("     ",) * 7,
}
SCALE = 2
PAD = 6
INK = np.array([230, 230, 230], np.uint8)
PAPER = np.array([20, 20, 20], np.uint8)


def text_mask(text: str) -> np.ndarray:
    """Pixels of ``text`` (True where inked), one pixel between letters; a letter without a glyph is blank."""
    rows = [" ".join(GLYPHS.get(ch, GLYPHS[" "])[row] for ch in text) for row in range(7)]
    return np.array([[c == "#" for c in row] for row in rows], bool)


def with_legend(picture: np.ndarray, names: tuple[str, ...], colours: np.ndarray) -> np.ndarray:
    """``picture`` (rows, columns, RGB) with a strip below it naming each colour, as many entries a line as fit."""
    entries = [_entry(name, colour) for name, colour in zip(names, colours, strict=True)]
    height = max(e.shape[0] for e in entries) + 2 * PAD
    lines, line, width = [], [], PAD
    for entry in entries:
        if line and width + entry.shape[1] + PAD > picture.shape[1]:
            lines.append(line)
            line, width = [], PAD
        line.append(entry)
        width += entry.shape[1] + 2 * PAD
    lines.append(line)
    strip = np.empty((height * len(lines), picture.shape[1], 3), np.uint8)
    strip[:] = PAPER
    for i, line in enumerate(lines):
        x = PAD
        for entry in line:
            h, w = entry.shape[:2]
            w = min(w, picture.shape[1] - x)
            if w > 0:
                strip[i * height + PAD:i * height + PAD + h, x:x + w] = entry[:, :w]
            x += entry.shape[1] + 2 * PAD
    return np.concatenate([picture, strip])


def _entry(name: str, colour: np.ndarray) -> np.ndarray:
    mask = text_mask(name).repeat(SCALE, axis=0).repeat(SCALE, axis=1)
    side = mask.shape[0]
    entry = np.empty((side, side + PAD + mask.shape[1], 3), np.uint8)
    entry[:] = PAPER
    entry[:, :side] = colour
    entry[:, side + PAD:][mask] = INK
    return entry
