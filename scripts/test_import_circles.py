"""The crate has no import circle (scripts/import_circles.py), and the check sees one."""

import os

import import_circles

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_the_crate_has_no_import_circle():
    assert import_circles.circles(ROOT) == []


def test_a_circle_is_found(tmp_path):
    src = tmp_path / "src"
    (src / "a").mkdir(parents=True)
    (tmp_path / "integrators").mkdir()
    (src / "lib.rs").write_text("pub mod a;\npub mod b;\n")
    (src / "a" / "mod.rs").write_text("mod x;\nmod y;\n")
    # x -> y through super::, y -> x through crate::; b only uses a (no circle).
    (src / "a" / "x.rs").write_text("use super::y::Thing;\n")
    (src / "a" / "y.rs").write_text("// use super::x::Other; (a comment)\nfn f() { crate::a::x::g(); }\n")
    (src / "b.rs").write_text("use crate::a::x::Other;\n")
    assert import_circles.circles(str(tmp_path)) == [["crate::a::x", "crate::a::y"]]
    # Comments are not imports.
    (src / "a" / "y.rs").write_text("// use super::x::Other;\n")
    assert import_circles.circles(str(tmp_path)) == []
