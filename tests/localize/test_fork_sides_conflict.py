"""A fork whose parent's two sides disagree at it, an occluder cutting one side in one view (forkends'
SIDES_CONFLICT_WITHHELD and the steep pieces' width rule; issue 5, docs/localize-forkgross.md): constructed pairs."""

import cv2
import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize import Localizer

from .shapes import ideal_rig, y_pair


def occluded_y(cut_end_px: float):
    """A vertical parent (radius 7 px, from row 200) with a child leaving it at 75 deg at row 300, both
    1000 mm away (84 px of disparity), and in the left view only a thin occluder (a leaf's edge, 1.5 px
    wide, background grey) crossing the parent's outline opposite the child at a shallow angle: from 1 px
    inside it at row 260 to ``cut_end_px`` - 313 px inside at row 296. Its rows there are cut short on
    the left in that view alone (a sliver left outside the cut): the upper side's crossings next to the
    fork are moved right, its fit bent by ~1 px at the fork, while the lower side's are the parent's.

    Returns (left BGR, right BGR, left mask, right mask, disparity px)."""
    calib = ideal_rig()
    left, right, ml, mr, _, d = y_pair(calib, 1000.0, 75.0, parent_radius_px=7.0, child_radius_px=4.2)
    for im in (left, right, ml, mr):
        im[:200] = 40 if im.ndim == 3 else 0
    ss = 8
    big = np.zeros((left.shape[0] * ss, left.shape[1] * ss), np.uint8)
    cv2.line(big, (313 * ss, 260 * ss), (int(cut_end_px * ss), 296 * ss), 255, int(1.5 * ss))
    cov = cv2.resize(big, (left.shape[1], left.shape[0]), interpolation=cv2.INTER_AREA).astype(float)[..., None] / 255
    left[:] = np.rint(left * (1 - cov) + 40 * cov).astype(np.uint8)
    ml[cov[..., 0] >= 0.5] = 0
    return calib, left, right, ml, mr, d


def forks(calib, left, right, ml, mr) -> list:
    res = Localizer(calib, load_config().localize).localize(left, right, mask_left=ml, mask_right=mr)
    return [f for f in res.features if f.kind == "bifurcation"]


@pytest.mark.parametrize("withheld", [False, True])
def test_a_fork_whose_sides_both_known_there_disagree_is_withheld(monkeypatch, withheld):
    # both parent sides are known at the fork from their own rows (the upper side's fitted span
    # reaches it, the lower one is read from its crossings next to it) and differ by ~1 px: one of them
    # is another shape's there, and which one nothing tells; their weighted mean was ~0.5 px off
    # (main: reported, 5-6 mm at 1000 mm; 0.33 px with forkdisp.weigh_bent_sides, the side read next to
    # the fork counting more than the one whose fit is carried to it); the fork is withheld
    import appliance.localize.forkends as forkends
    from appliance.localize import kernels_dense
    monkeypatch.setattr(forkends, "SIDES_CONFLICT_WITHHELD", withheld)
    # steepdrift's width rule (kernels_dense.width_disagree) drops this drawn cut's rows from the upper
    # side's fit and the fork is then reported 0.02 px off: rule 1 is for the cuts it does not correct
    monkeypatch.setattr(kernels_dense, "OCCL_TOL_PX", -1.0)
    calib, left, right, ml, mr, d = occluded_y(316.25)
    found = forks(calib, left, right, ml, mr)
    if withheld:
        assert found == []
    else:
        assert len(found) == 1 and (found[0].left_px[0] - found[0].right_px[0]) - d >= 0.3


def test_a_fork_whose_side_is_cut_in_one_view_is_reported_right_with_the_width_rule():
    # the same drawing with steepdrift's width rule on: the cut rows leave the upper side's fit, the sides
    # agree and the fork stands at the truth (measured 0.02 px)
    calib, left, right, ml, mr, d = occluded_y(316.25)
    found = forks(calib, left, right, ml, mr)
    assert len(found) == 1 and abs((found[0].left_px[0] - found[0].right_px[0]) - d) <= 0.15


def test_a_fork_whose_sides_agree_within_a_pixel_stands():
    # the occluder cutting less: the upper side ~0.7 px off at the fork, within one branch's
    # tolerance of the lower one; the fork is reported (their weighted mean)
    calib, left, right, ml, mr, d = occluded_y(315.5)
    found = forks(calib, left, right, ml, mr)
    assert len(found) == 1 and abs((found[0].left_px[0] - found[0].right_px[0]) - d) <= 0.4
