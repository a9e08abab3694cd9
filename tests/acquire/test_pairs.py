from appliance.acquire.pairs import find_pairs


def touch(folder, *names):
    for n in names:
        (folder / n).write_bytes(b"")


def test_pairs_by_name_in_natural_order(tmp_path):
    touch(tmp_path, "left10.png", "right10.png", "left02.jpg", "right02.jpg", "left_3.bmp", "right_3.bmp",
          "L7.tif", "R7.tif", "notes.txt")
    pairs, unpaired = find_pairs(tmp_path)
    assert [p.key for p in pairs] == ["02", "3", "7", "10"]
    assert pairs[0].left.name == "left02.jpg" and pairs[0].right.name == "right02.jpg"
    assert pairs[2].left.name == "L7.tif" and pairs[2].right.name == "R7.tif"
    assert unpaired == []


def test_images_without_partner_are_reported(tmp_path):
    touch(tmp_path, "left01.png", "right01.png", "left02.png", "photo.png")
    pairs, unpaired = find_pairs(tmp_path)
    assert [p.key for p in pairs] == ["01"]
    assert sorted(p.name for p in unpaired) == ["left02.png", "photo.png"]


def test_prefixed_names_pair(tmp_path):
    touch(tmp_path, "scene_00_left.png", "scene_00_right.png")
    pairs, _ = find_pairs(tmp_path)
    assert [p.key for p in pairs] == ["scene_00"]
