"""The paper's modes matched to ours by kind (torchrom.paper.modes)."""

from torchrom.paper.modes import paper_mode_map
from torchrom.reference import paper_reference


def test_paper_mode_4_maps_to_our_first_free_out_of_plane_mode():
    # our reconstruction's first nine modes (docs/paper/report.md, Table 2)
    ours = ["bending", "torsion", "bending", "in-plane", "torsion", "torsion", "bending",
            "torsion", "torsion"]
    m = paper_mode_map(ours, paper_reference().table2_kinds)
    assert m == {1: 1, 2: 2, 3: 3, 4: 5, 5: 4}


def test_identical_ordering_maps_to_itself_and_missing_kinds_are_left_out():
    paper = paper_reference().table2_kinds
    assert paper_mode_map(["bending", "torsion", "bending", "torsion", "in-plane"], paper) == {
        1: 1, 2: 2, 3: 3, 4: 4, 5: 5}
    assert paper_mode_map(["bending", "bending"], paper) == {1: 1, 3: 2}


def test_reference_values_are_the_papers():
    ref = paper_reference()
    assert ref.table2_hz[0] == 1.690 and len(ref.table2_hz) == 9
    assert (ref.flutter_altitude_ft, ref.flutter_frequency_hz) == (11275.0, 1.975)
    assert ref.table3_hz[4000.0] == 1.851 and ref.alpha0_per_s == 0.2565


def test_kind_label_gives_the_shares_of_a_mixed_mode():
    from torchrom.paper.modes import kind_label, kind_margin

    mixed = {"bending": 0.438, "torsion": 0.262, "in-plane": 0.294, "axial": 0.007}
    assert kind_label("bending", mixed) == "bending (0.44 bending, 0.29 in-plane, 0.26 torsion)"
    assert kind_label("bending", mixed, short=True) == "bending (b .44, ip .29, t .26)"
    assert kind_label("bending", {"bending": 0.999, "torsion": 0.001}) == "bending"
    assert kind_label("torsion") == "torsion" and kind_label(None) == "unknown kind"
    assert kind_margin(mixed) == ("bending", 0.438, "in-plane", 0.294)
