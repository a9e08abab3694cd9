import cv2
import numpy as np
from appliance.localize.graph import ENDPOINT, JUNCTION, build_graph
from appliance.localize.prune import prune
from appliance.localize.radius import ridge_radius_map
from appliance.localize.skeleton import Skeleton

from .shapes import y_shape


def _line_with_spur(spur_px: int) -> Skeleton:
    img = np.zeros((60, 200), np.uint8)
    img[30, 20:180] = 1
    img[30 - spur_px:30, 100] = 1
    return Skeleton(img)


def test_a_3px_spur_is_pruned():
    g0 = build_graph(_line_with_spur(3))
    assert (g0.node_kind == JUNCTION).sum() == 1 and (g0.node_kind == ENDPOINT).sum() == 3
    _, g = prune(_line_with_spur(3), min_length_px=5.0)
    assert (g.node_kind == JUNCTION).sum() == 0
    assert (g.node_kind == ENDPOINT).sum() == 2
    assert len(g.seg_nodes) == 1


def test_a_long_side_branch_is_kept():
    _, g = prune(_line_with_spur(15), min_length_px=5.0)
    assert (g.node_kind == JUNCTION).sum() == 1
    assert (g.node_kind == ENDPOINT).sum() == 3


def test_radius_factor_prunes_spurs_relative_to_the_branch_thickness():
    mask = np.zeros((120, 300), np.uint8)
    cv2.line(mask, (20, 60), (280, 60), 255, 25)           # radius ~12 px
    spur = _line_with_spur(9).image
    skel = Skeleton(np.pad(spur, ((30, 30), (50, 50)))[:120, :300])
    rmap = ridge_radius_map(mask)
    _, kept = prune(skel, 5.0, radius_factor=0.0, radius_map=rmap)
    assert (kept.node_kind == JUNCTION).sum() == 1
    _, pruned = prune(skel, 5.0, radius_factor=1.5, radius_map=rmap)
    assert (pruned.node_kind == JUNCTION).sum() == 0


def test_pruning_repeats_until_stable_and_leaves_the_y_alone():
    from appliance.localize.skeleton import skeletonize

    skel = skeletonize(y_shape())
    _, g = prune(skel, 5.0)
    assert (g.node_kind == JUNCTION).sum() == 1 and (g.node_kind == ENDPOINT).sum() == 3


def _skeleton_with_spurs(spurs: list[tuple[int, int]]) -> Skeleton:
    """A line across the image's row 8 with vertical spurs (column, top row) up from it."""
    img = np.zeros((60, 200), np.uint8)
    img[8, 20:180] = 1
    for col, top in spurs:
        img[top:8, col] = 1
    return Skeleton(img)


def test_a_short_spur_running_out_of_the_view_is_kept_as_a_branch_leaving_it():
    skel = _skeleton_with_spurs([(100, 0)])          # 8 px up to the image's top row
    _, g = prune(skel, 10.0)
    assert (g.node_kind == JUNCTION).sum() == 0      # the paper's rule: any short spur goes
    _, g = prune(skel, 10.0, keep_border=True)
    assert (g.node_kind == JUNCTION).sum() == 1
    assert (g.node_kind == ENDPOINT).sum() == 3
    _, g = prune(_skeleton_with_spurs([(100, 2)]), 10.0, keep_border=True)
    assert (g.node_kind == JUNCTION).sum() == 0      # a short spur ending inside the view goes


def test_two_spurs_of_one_junction_at_the_edge_are_the_corners_of_a_cut_branch():
    img = np.zeros((60, 200), np.uint8)
    img[20:60, 100] = 1                               # a branch up to a V reaching the top edge
    for k in range(1, 21):
        img[20 - k, 100 - k] = img[20 - k, 100 + k] = 1
    skel = Skeleton(img)
    assert (build_graph(skel).node_kind == JUNCTION).sum() == 1
    _, g = prune(skel, 30.0, keep_border=True)
    assert (g.node_kind == JUNCTION).sum() == 0
    assert (g.node_kind == ENDPOINT).sum() == 2
