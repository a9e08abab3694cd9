"""Find left/right image pairs in a folder by their names."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")

# left01.png / right01.png, left_3.jpg / right_3.jpg, L7.bmp / R7.bmp, cam_left_2 / cam_right_2
_SIDE = re.compile(r"(?i)(?P<pre>.*?)(?P<side>left|right|(?<![a-z])[lr](?=[_\-.]?\d))(?P<post>.*)")


@dataclass(frozen=True)
class ImagePair:
    """One left/right pair and the key that joined them (the name without the side)."""

    key: str
    left: Path
    right: Path


def find_pairs(folder: str | Path) -> tuple[list[ImagePair], list[Path]]:
    """Pair the images of ``folder`` by name.

    Parameters
    ----------
    folder : str or Path
        Folder with images named ``left01.png``/``right01.png``, ``left_3.jpg``/``right_3.jpg``
        or ``L7.bmp``/``R7.bmp`` (case-insensitive; png, jpg, bmp, tif).

    Returns
    -------
    pairs : list of ImagePair
        Sorted naturally by key (``2`` before ``10``).
    unpaired : list of Path
        Images that have no partner or no side in their name.
    """
    files = sorted(p for p in Path(folder).iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    sides: dict[str, dict[str, Path]] = {}
    unpaired = []
    for path in files:
        m = _SIDE.fullmatch(path.stem)
        if not m:
            unpaired.append(path)
            continue
        side = "left" if m["side"].lower().startswith("l") else "right"
        key = f"{m['pre']}{m['post']}".strip("_-.") or "0"
        if side in sides.setdefault(key.lower(), {}):
            unpaired.append(path)
            continue
        sides[key.lower()][side] = path
    pairs = []
    for key, both in sides.items():
        if len(both) == 2:
            pairs.append(ImagePair(key, both["left"], both["right"]))
        else:
            unpaired.extend(both.values())
    pairs.sort(key=lambda p: _natural(p.key))
    return pairs, sorted(unpaired)


def _natural(text: str):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", text)]
