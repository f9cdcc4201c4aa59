"""One --cull grammar (issue 31): + joins stages everywhere, compare lists combinations with ';'
or repeated --cull, the older ',' still works with a note; aligned play/view defaults; the
top-level help; unknown worlds."""
import json

from vismobile.app.cli import build_parser, main
from vismobile.commands import DEFAULT_CULL, DEFAULT_STRUCTURE, default_cull
from vismobile.study.matrix import ambiguous_commas, cull_items, parse_culls


def test_compare_lists_combinations_with_semicolons_or_repeated_options():
    assert parse_culls("vfc+bfc;vfc+occlusion") == ["vfc+bfc", "vfc+occlusion"]
    assert parse_culls(["vfc+bfc", "none"]) == ["vfc+bfc", "none"]
    assert parse_culls("vfc+bfc; none") == parse_culls("vfc+bfc none") == ["vfc+bfc", "none"]
    assert cull_items(["thesis", "vfc+cone;tbfc"]) == ["thesis", "vfc+cone", "tbfc"]
    # The older comma still separates combinations, and is noted when it may have meant +.
    assert parse_culls("vfc,bfc") == ["vfc", "bfc"]
    note = ambiguous_commas("vfc,bfc")
    assert "2 of them: vfc; bfc" in note and "(vfc+bfc)" in note
    assert ambiguous_commas(["vfc+bfc;none", "thesis"]) is None
    assert ambiguous_commas("all,ours") is None


def test_compare_parses_repeated_cull_options():
    args = build_parser().parse_args(["compare", "--cull", "vfc+bfc", "--cull", "none"])
    assert args.cull == ["vfc+bfc", "none"]
    assert build_parser().parse_args(["compare"]).cull is None  # -> all


def test_play_and_view_start_alike():
    play = build_parser().parse_args(["play", "w1", "-o", "x"])
    view = build_parser().parse_args(["view", "w1"])
    assert play.structure == view.structure == DEFAULT_STRUCTURE
    assert default_cull(play.cull, play.structure) == default_cull(view.cull, view.structure)
    assert default_cull(None, "octree:4") == DEFAULT_CULL and default_cull(None, "none") == "none"


def test_play_uses_the_thesis_path_of_a_thesis_world(tmp_path, capsys):
    assert main(["play", "w5", "--limit", "3", "--quiet", "-o", str(tmp_path / "run")]) == 0
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["frames"] == 3 and summary["structure"] == DEFAULT_STRUCTURE
    assert summary["stages"] == [DEFAULT_CULL]
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert main(["play", str(tmp_path / "m.obj"), "-o", str(tmp_path / "m")]) == 2
    assert "needs --trajectory" in capsys.readouterr().err


def test_top_level_help_and_unknown_world(capsys):
    help_text = build_parser().format_help()
    assert "first steps:" in help_text and "vismobile play w2" in help_text
    assert "Command-line entry point" not in help_text
    assert main(["info", "w9"]) == 2
    err = capsys.readouterr().err
    assert "w9: unknown world" in err and "unsupported mesh format" not in err


def test_hostile_cull_lists_end_in_one_clean_error():
    import random

    from vismobile.errors import VisMobileError

    rng = random.Random(31)
    alphabet = "vfcbotlusinpre_+,; \n\t\x00é" + "".join(chr(c) for c in range(33, 127, 7))
    for _ in range(400):
        text = "".join(rng.choice(alphabet) for _ in range(rng.randrange(0, 40)))
        ambiguous_commas(text)
        try:
            for label in parse_culls(text) + parse_culls(text.split("\n")):
                assert label == "none" or all(s.isidentifier() for s in label.split("+"))
        except VisMobileError:
            pass
