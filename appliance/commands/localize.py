"""`appliance localize`: branches of one stereo pair in 3D, as JSON (and an overlay picture)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from appliance.commands.common import ConfigOption, effective_config, output_paths


def read_image(path: Path, what: str, grey: bool = False):
    """An image file as a numpy array; LocalizeError naming the file if it cannot be read."""
    import cv2

    from appliance.localize.errors import LocalizeError

    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_COLOR) if path.is_file() else None
    if img is None:
        reason = "not found" if not path.exists() else "not a readable image"
        raise LocalizeError(f"{path}: {what} {reason}")
    return img


def mask_from_file(img):
    """A mask file's pixels as the localizer takes them: binary (two values at most: non-zero =
    branch) as they are; grey levels between (a segmenter's probability map saved as 8 bits, or
    the anti-aliased outline of a drawn mask) as a probability, value / 255, kept soft."""
    import numpy as np

    lo, hi = int(img.min()), int(img.max())
    if np.count_nonzero((img != lo) & (img != hi)) == 0:
        return img
    return img.astype(np.float32) / 255.0


def load_inputs(calib_path: Path, left: Path, right: Path, mask_left: Path | None, mask_right: Path | None):
    """Calibration, images and optional masks, checked: sizes match the calibration."""
    from appliance.calibrate.model import load_calibration
    from appliance.localize.errors import LocalizeError

    if (mask_left is None) != (mask_right is None):
        raise typer.BadParameter("give both --mask-left and --mask-right, or neither")
    calib = load_calibration(calib_path)
    w, h = calib.image_size
    images = [read_image(left, "left image"), read_image(right, "right image")]
    masks = [read_image(p, "mask", grey=True) for p in (mask_left, mask_right) if p is not None]
    for path, img in zip([left, right, mask_left, mask_right], images + masks):
        if img.shape[:2] != (h, w):
            raise LocalizeError(f"{path}: image is {img.shape[1]}x{img.shape[0]}, the calibration {calib_path} "
                                f"is for {w}x{h}")
    masks = [mask_from_file(m) for m in masks]
    for path, m in zip((mask_left, mask_right), masks):
        if not ((m >= 0.5) if m.dtype.kind == "f" else m).any():
            raise LocalizeError(f"{path}: mask is empty (no branch pixel)")
    return calib, images, (masks or [None, None])


def command(
    left: Annotated[Path, typer.Argument(help="Left image (original, as captured).")],
    right: Annotated[Path, typer.Argument(help="Right image.")],
    calib: Annotated[Path, typer.Option("--calib", help="Stereo calibration (appliance calibrate).")],
    json_out: Annotated[Path, typer.Option("--json", help="Result file to write (JSON).")],
    overlay: Annotated[Path | None, typer.Option("--overlay", help="Also draw the result into this PNG.")] = None,
    paper: Annotated[bool, typer.Option("--paper", help="Run the paper's method instead of the improved one.")] = False,
    mask_left: Annotated[Path | None, typer.Option(
        "--mask-left", help="Branch mask of the left image from an external segmenter: 0/non-zero, or grey levels "
                            "0-255 as a probability (soft outline).")] = None,
    mask_right: Annotated[Path | None, typer.Option("--mask-right", help="Branch mask of the right image.")] = None,
    config: ConfigOption = None,
) -> None:
    """Localize the branches of one stereo pair: tips and forks in 3D (mm, left camera frame), branches as
    cylinders, safe depths. No branch found is an empty result, not an error."""
    import cv2

    from appliance.localize import Localizer
    from appliance.localize.overlay import draw_overlay

    cfg = effective_config(config)
    cal, (img_l, img_r), (m_l, m_r) = load_inputs(calib, left, right, mask_left, mask_right)
    output_paths(json_out, overlay)
    variant = "paper" if paper else "improved"
    result = Localizer(cal, cfg.localize, variant).localize(img_l, img_r, mask_left=m_l, mask_right=m_r)
    data = result.to_dict() | {"variant": variant}
    json_out.write_text(json.dumps(data, indent=1) + "\n")
    n_tip = sum(f.kind == "endpoint" for f in result.features)
    typer.echo(f"{len(result.features)} features ({n_tip} tips, {len(result.features) - n_tip} forks), "
               f"{len(result.branches)} branch pieces ({variant}, {result.timings_ms.get('total', 0.0):.0f} ms)")
    typer.echo(f"wrote {json_out}")
    if overlay is not None:
        img = draw_overlay(img_l, img_r, result, cal, tuple(cfg.localize.working_range_mm))
        if not cv2.imwrite(str(overlay), img):
            from appliance.localize.errors import LocalizeError

            raise LocalizeError(f"{overlay}: cannot write the overlay image")
        typer.echo(f"wrote {overlay}")
