"""A thick branch's silhouette centre against its axis: the disparity of the middle of its row crossings.

A cylinder of radius R whose axis lies at the ray angle theta (``tan theta = x``, normalised image column) is
seen between the two tangent rays at ``theta +- a`` (``sin a = R / rho``, ``rho`` the axis's distance). In the
image (``f tan``) their middle lies ``f x tan^2 a (1 + x^2)`` (to leading order) beyond the axis's own image,
away from the principal point: ``X (r / f)^2 / (1 + x^2)`` px with ``X = f x`` and ``r`` the image radius
(``f R / (rho sqrt(1 + x^2))``). The two rectified views see the axis at the same depth, ``X`` differing by the
disparity, so the crossings' middles are ``(d - offset) (r / f)^2 / (1 + x^2)`` px further apart than the
axis: +0.02 px for a 15 px radius at 175 px of disparity, +0.07 px for 25 px (seeds 100-155 and 260-483: the
steep forks' row crossings read 0.04 px high at the median, as predicted by radius; docs/localize-forkacc20.md).
"""

from __future__ import annotations


def centre_bias_px(d_px: float, u_px: float, radius_px: float, f_px: float, cx_px: float,
                   offset_px: float = 0.0) -> float:
    """How much further apart (px) the two views' row-crossing middles of a round branch are than its axis.

    Parameters
    ----------
    d_px : float
        The crossings' disparity (px, rectified: left column minus right column).
    u_px : float
        The left view's column of the branch (px, rectified).
    radius_px : float
        The branch's radius in the left image (px, square to its axis).
    f_px, cx_px, offset_px : float
        Rectified focal length, the left principal point's column and ``cx_left - cx_right`` (px).

    Returns
    -------
    float
        The bias (px) to subtract from ``d_px`` for the axis's disparity; >= 0 in front of the rig.
    """
    x = (u_px - cx_px) / f_px
    return (d_px - offset_px) * (radius_px / f_px) ** 2 / (1.0 + x * x)
