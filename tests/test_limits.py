"""The walk's fixed-capacity buffers: an overflow ends the ray's walk there, is counted,
and is reported once with where it happened and the option that raises the limit."""
from pathlib import Path

import numpy as np
import pytest

import pcsg
from pcsg.cli import main
from pcsg.graph import bounds
from pcsg.limits import cli_option
from pcsg.trace.nodes import EV_INTERVALS, EV_STACK, EV_VISITS
from tests.conftest import GRAMMARS, SIERPINSKI

ROW = """// a row of spheres along x, built by recursion
{ n = 40 } ROW
ROW if(n > 0, 2, 1)
1: ROW → sphere
2: ROW → sphere ∪ { n = n - 1 } move(2.5, 0, 0) ROW
"""
# the same row clipped: a ray along it meets 41 pieces inside one ∩
CLIPPED = ROW.replace("{ n = 40 } ROW", "{ n = 40 } (ROW ∩ scale(200, 2, 2) cube)")
# its spheres in a module: seen from the far end, every level leaves its own ball pending
# on the stack, nearest box first (a sphere, a cheap operand, is tested at once)
BALLS = ROW.replace("sphere ∪", "BALL ∪") + "BALL 1\n1: BALL → sphere\n"


def test_a_full_walk_stack_is_reported_with_the_option_that_raises_it():
    o, d = [[200.0, 0, 0]], [[-1.0, 0, 0]]
    full = pcsg.loads(BALLS).trace(o, d)
    assert full.events[EV_STACK].sum() == 0 and full.t[0] == pytest.approx(99.0)
    small = pcsg.loads(BALLS, "row.pcsg", stack_depth=16)
    h = small.trace(o, d)
    assert h.events[EV_STACK].sum() == 1
    assert h.hit[0] and h.t[0] > full.t[0]        # it lost the far balls, nothing else
    (line,) = small.describe_events(h.events)
    assert line.startswith("walk stack full 1 times (union at row.pcsg:5:15, depth up to ")
    assert line.endswith("raise stack_depth (now 16)")
    (line,) = small.describe_events(h.events, option=cli_option)     # render's
    assert line.endswith("raise --stack-depth (now 16)")


@pytest.mark.parametrize("operator", ["∩", "∪", "\\"])
def test_the_default_stack_holds_a_deep_nest_of_operators(operator):
    """The default stack followed --max-depth and the widest union, not the nesting of
    the expression: `(a ∩ (b ∩ (c ∩ ...)))` 300 deep filled its 166 frames, and drew
    nothing (QA). The default finds what a stack of 5,000 frames finds."""
    from pcsg.tracer import operator_nesting
    text = "sphere"
    for i in range(300):
        text = f"(move({i % 3 * 0.001}, 0, 0) sphere {operator} {text})"
    obj = pcsg.loads(text)
    assert obj.stack_depth >= 2 * operator_nesting(obj.flat) >= 300    # ∪ spliced in twos
    o, d = [[-5.0, 0, 0.1], [0, -5, 0.2]], [[1.0, 0, 0], [0, 1, 0]]
    h = obj.trace(o, d)
    assert h.events[EV_STACK].sum() == 0
    deep = pcsg.loads(text, stack_depth=5000).trace(o, d)
    assert h.t.tolist() == deep.t.tolist() and h.hit.tolist() == deep.hit.tolist()
    assert h.hit.all() or operator == "\\"
    # a rule's nest counts from its S-node again: one union in Sierpinski's rule
    assert operator_nesting(pcsg.loads(SIERPINSKI).flat) == 1


def test_full_interval_lists_are_reported_with_the_option_that_raises_it():
    o, d = [[-5.0, 0, 0]], [[1.0, 0, 0]]
    assert pcsg.loads(CLIPPED).trace(o, d).events[EV_INTERVALS].sum() == 0
    small = pcsg.loads(CLIPPED, "row.pcsg", interval_rows=16)
    h = small.trace(o, d)
    assert h.events[EV_INTERVALS].sum() > 0 and h.t[0] == pytest.approx(4.0)
    (line,) = small.describe_events(h.events)
    assert "primitive at row.pcsg:4:10, depth up to 41" in line
    assert line.endswith("raise interval_rows (now 16)")
    (line,) = small.describe_events(h.events, option=cli_option)
    assert line.endswith("raise --interval-rows (now 16)")


def test_the_render_names_the_overflow_and_strict_fails_on_it(capsys, tmp_path):
    src = tmp_path / "row.pcsg"
    src.write_text(BALLS.replace("{ n = 40 } ROW", "{ n = 40 } move(-50, 0, 0) ROW"),
                   encoding="utf-8")
    out = tmp_path / "row.png"
    args = ["render", str(src), "-o", str(out), "--size", "48x24", "-q", "--no-shadows",
            "--eye", "120,0,0", "--at", "0,0,0", "--fov", "20"]
    assert main(args) == 0
    assert "walk stack full" not in capsys.readouterr().err
    before = out.read_bytes()
    assert main(args + ["--stack-depth", "16"]) == 0
    err = capsys.readouterr().err
    assert "walk stack full" in err and "raise --stack-depth (now 16)" in err
    assert out.read_bytes() != before
    out.unlink()
    assert main(args + ["--stack-depth", "16", "--strict"]) == 1
    assert "walk stack full" in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize("flag, value", [("--stack-depth", "4"), ("--stack-depth", "10000000"),
                                         ("--interval-rows", "0"),
                                         ("--interval-rows", "100000000"),
                                         ("--max-instances", "0"),
                                         ("--max-instances", str(10 ** 23)),
                                         ("--bounds-budget", "0")])
def test_buffer_sizes_out_of_range_are_usage_errors(capsys, flag, value):
    assert main(["render", "x.pcsg", flag, value]) == 2
    err = capsys.readouterr().err
    assert f"{flag} {value}: use " in err       # the range, not "give a positive number"


def test_the_events_keep_the_deepest_level_across_chunks():
    from pcsg.trace.nodes import N_EVENTS, add_events, no_events
    ev = no_events(2, chunks=3)
    ev[0, EV_STACK, 1], ev[0, N_EVENTS + EV_STACK, 1] = 2, 7
    ev[2, EV_STACK, 1], ev[2, N_EVENTS + EV_STACK, 1] = 1, 3
    total = add_events(no_events(2), ev)
    assert total[EV_STACK, 1] == 3 and total[N_EVENTS + EV_STACK, 1] == 7
    assert np.count_nonzero(total) == 2


ENDLESS = """// neither ends nor contracts: 2^depth instances behind every ray that misses
{ n = 1 } S
S 1
1: S → sphere ∪ move(3, 0, 0) S ∪ move(0, 3, 0) S
"""


def test_a_ray_stops_after_its_budget_of_instances():
    obj = pcsg.loads(ENDLESS, "endless.pcsg", max_instances=2000)
    h = obj.trace([[-5.0, -5, 5], [-5, 0, 0]], [[0.3, 0.3, 1], [1, 0, 0]])
    # unbounded boxes prune nothing: both rays run out, the second keeps the hit it found
    assert h.events[EV_VISITS].sum() == 2
    assert list(h.hit) == [False, True] and h.t[1] == pytest.approx(4.0)
    line = obj.describe_events(h.events, option=cli_option)[-1]
    assert line.startswith("2 rays stopped after entering --max-instances 2,000 instances "
                           "('S' at endless.pcsg:3:1, depth up to ")
    assert line.endswith("raise --max-instances to go on")
    line = obj.describe_events(h.events)[-1]
    assert line.startswith("2 rays stopped after entering max_instances=2,000 instances ")
    assert line.endswith("raise max_instances to go on")


def test_rays_walked_together_stop_after_the_same_budget_as_alone():
    # sixteen neighbouring rays run out in one packet frame (packet.select drops them
    # there), two of them after a hit
    obj = pcsg.loads(ENDLESS, "endless.pcsg", max_instances=500)
    u = np.linspace(0.0, 0.05, 4)
    o = np.array([[-5.0 + a, -5.0 + b, 5.0] for a in u for b in u])
    d = np.tile([0.3, 0.3, 1.0], (16, 1))
    o[:2] = [[-5.0, 0, 0], [-5.0, 0.01, 0]]
    d[:2] = [1.0, 0, 0]
    together, alone = obj.trace(o, d), obj.trace(o, d, packets=False)
    assert together.events[EV_VISITS].sum() == alone.events[EV_VISITS].sum() == 16
    assert list(together.hit) == list(alone.hit) == [True] * 2 + [False] * 14
    assert np.array_equal(together.t, alone.t)


def test_a_packet_whose_rays_together_pass_the_budget_finds_what_they_find_alone():
    """packet.trace counts the packet's selections, not each ray's entries, and starts
    again counting each ray's where those pass --max-instances. A packet of 256 rays
    spread over the Sierpinski tetrahedron at 4 selects in most of its 341 instances, far
    more than one of its rays enters: with a budget a little above what one ray needs, it
    starts again, and must then find every hit and report no ray stopped, as it does when
    the budget is never near; a budget below, the rays that run out are the same as alone."""
    text = SIERPINSKI.replace("c = 6", "c = 4")
    u = np.linspace(-0.9, 0.9, 16)
    o = np.array([[a, b, 3.0] for a in u for b in u])
    d = np.tile([0.05, 0.02, -1.0], (len(o), 1))
    free = pcsg.loads(text, max_instances=1 << 30).trace(o, d)
    assert free.hit.sum() > 100 and free.events[EV_VISITS].sum() == 0
    need = next(b for b in range(1, 341)
                if pcsg.loads(text, max_instances=b).trace(o, d, packets=False)
                .events[EV_VISITS].sum() == 0)
    assert need < 60        # so the packet's 341-odd selections pass 2 * need
    tight = pcsg.loads(text, max_instances=2 * need).trace(o, d)
    assert tight.events.sum() == free.events.sum() == 0
    assert np.array_equal(tight.hit, free.hit) and np.array_equal(tight.t, free.t)
    assert np.array_equal(tight.normal, free.normal)
    short = pcsg.loads(text, max_instances=need // 2)
    together, alone = short.trace(o, d), short.trace(o, d, packets=False)
    assert alone.events[EV_VISITS].sum() > 0
    assert np.array_equal(together.hit, alone.hit) and np.array_equal(together.t, alone.t)


def test_an_empty_box_culls_every_ray(monkeypatch):
    """The compiled box walk leaves a graftal empty (only the memoised walk bounds its
    attractor). An empty box must cull every ray: a slab test alone makes it all of
    space, and the walk would descend every instance (here: run out of its budget)."""
    monkeypatch.setattr(bounds, "MAX_STATES", 0)
    obj = pcsg.loads("{ n = 1 } S\nS 1\n"
                     "1: S → move(1, 0, 0) uscale(0.5) S ∪ move(-1, 0, 0) uscale(0.5) S\n",
                     max_depth=12, max_instances=100)
    assert obj.bounds_method == "every instance"
    assert obj.bounds[0] > obj.bounds[3]
    h = obj.trace([[-5.0, 0, 0], [0, 0, 5]], [[1.0, 0, 0], [0, 0, -1]])
    assert not h.hit.any() and h.events.sum() == 0


def test_the_bounds_budget_decides_how_deep_a_large_system_is_bounded(capsys, tmp_path):
    """--bounds-budget reaches the bounding walk: the terrain at 7 (depth 9, 43 691 S-node
    instances, 305 838 node visits) is bounded in full by default, and with a budget of
    150 000 visits only down to the depth that fits, which the render says; both write a
    picture."""
    terrain = str(Path(__file__).resolve().parent.parent / "grammars" / "carpenter_terrain.pcsg")
    args = ["render", terrain, "--set", "cnt=7", "--size", "32x24", "--no-shadows", "-q"]
    assert main(args + ["-o", str(tmp_path / "full.png")]) == 0
    assert "too many to bound" not in capsys.readouterr().err
    assert main(args + ["-o", str(tmp_path / "cut.png"), "--bounds-budget", "150000"]) == 0
    err = capsys.readouterr().err
    assert "too many to bound one by one" in err and "--bounds-budget 150,000" in err
    assert (tmp_path / "full.png").exists() and (tmp_path / "cut.png").exists()


def test_event_counts_are_said_as_ray_visits(tmp_path):
    # one instance met by many rays read "410 instances were empty", and the depth limit's
    # own next level "--max-depth 1 ... depth up to 2", as if past the limit
    obj = pcsg.loads("paint(0/0, 1, 1) sphere ∪ move(3, 0, 0) cube\n")
    o = np.tile([[0.0, -5.0, 0.0]], (50, 1))
    obj.trace(o, np.tile([[0.0, 1.0, 0.0]], (50, 1)))
    (line,) = obj.describe_events(obj.events)
    assert line == ("instances were empty because of a non-finite argument (paint at "
                    "<string>:1:1, depth up to 0; 50 ray visits)")
    deep = pcsg.loads(SIERPINSKI, max_depth=1)
    deep.trace(np.array([[3.0, -4.0, 2.0]]), np.array([[-3.0, 4.0, -2.0]]))
    (line,) = deep.describe_events(deep.events, option=cli_option)
    assert line.startswith("depth limit: instances at --max-depth 1 were finished with their "
                           "terminating rule ('S' at ")
    assert "depth up to" not in line and line.endswith("raise --max-depth to refine further")


@pytest.mark.parametrize("option", [dict(max_instances=-1), dict(max_instances=0),
                                    dict(max_depth=-1), dict(stack_depth=0),
                                    dict(interval_rows=-1), dict(bounds_budget=0),
                                    dict(max_depth="3")])
def test_the_api_refuses_the_limits_the_command_line_refuses(option):
    # max_instances=-1 made every ray a silent miss; stack_depth=0 meant the default
    with pytest.raises(ValueError, match=f"^{next(iter(option))}="):
        pcsg.loads("sphere", **option)
    assert pcsg.loads("sphere", bounds_budget=1e9).bounds_method == "memoised"


@pytest.mark.parametrize("budget, depth", [(1, 0), (100, 2), (700, 3)])
def test_a_budget_too_small_for_the_first_walk_bounds_a_shallower_depth(budget, depth):
    # the terrain at --bounds-budget 100: no box at all, minutes of render, and no word;
    # then a word, and still minutes (every ray walked every instance it met). A smaller
    # budget is a coarser picture: depth 0 is walked whatever the budget
    obj = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=6, bounds_budget=budget)
    assert obj.bounds_method == "every instance" and obj.max_depth == depth
    (w,) = obj.warnings
    # at depth 0 no max_depth is named: the argument takes 1 and more (QA)
    assert (f"refinement stops there, as with max_depth={depth}:" if depth else
            "refinement stops there: deeper") in w.message
    assert not pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=6).warnings
    hits = obj.trace(np.array([[0.5, 0.5, 5.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert hits.hit[0]              # the terrain, as its terminating rules make it there


def test_rays_a_limit_stopped_are_not_said_to_have_missed_an_empty_object(capsys, tmp_path):
    """An ∩ of copies 0.02 apart, 12 levels deep, stopped at --max-instances 16 on every
    ray: "no ray met the object: it is empty or out of the camera's view" said of an
    object that is neither."""
    src = tmp_path / "nest.pcsg"
    src.write_text("#camera eye=(0,-8,2) at=(0,0,0) fov=40\n{c = 12} S\nS if(c > 0, 2, 1)\n"
                   "1: S → sphere\n2: S → {c = c-1} (move(0.01,0,0) S ∩ move(-0.01,0,0) S)\n",
                   encoding="utf-8")
    args = ["render", str(src), "-o", str(tmp_path / "n.png"), "--size", "24x18",
            "--shadow-samples", "1", "-q"]
    assert main(args + ["--max-instances", "16"]) == 0
    err = capsys.readouterr().err
    assert "rays stopped after entering --max-instances 16 instances" in err
    assert "no ray met the object before a walk limit stopped it (above)" in err
    assert "empty or out of the camera's view" not in err
    assert main(args) == 0                      # without the limit it is drawn
    assert "no ray met" not in capsys.readouterr().err


def test_an_endless_system_too_large_to_walk_whole_is_told_to_take_a_depth():
    """Its maps read rand(), so only the walk of every instance bounds it, and a system
    that never ends only whole: "a larger budget bounds them" was no help (QA: over 60 s
    at 64x48, and 3 s at --max-depth 16)."""
    text = ("S\n1: S → scale(0.07,0.07,1) cylinder ∪ move(0,0,1) rotz(360*rand()) roty(30) "
            "uscale(0.6) S ∪ move(0,0,0.7) rotz(360*rand()) roty(45) uscale(0.5) S\n")
    obj = pcsg.loads(text)
    assert obj.bounds_method == "unbounded"
    (w,) = obj.warnings
    assert w.message.endswith("it never ends, and is bounded only walked whole, to "
                              "max_depth=64: a smaller max_depth (16, say) ends it where "
                              "its instances can be walked")
    cut = pcsg.loads(text, max_depth=12)
    assert cut.bounds_method == "every instance" and not cut.warnings


def test_a_render_says_it_will_be_slow_before_it_renders(capsys, tmp_path, monkeypatch):
    """"nothing is bounded, so every ray walks all the instances it meets (slow)" came
    after minutes of a silent render, and never where --timeout stopped it (QA)."""
    from pcsg.cli import main
    from pcsg.render import job
    src = tmp_path / "s.pcsg"
    src.write_text("S\nS 1\n1: S → S ∪ move(0.1,0,0) S ∪ sphere\n", encoding="utf-8")

    def stopped(*args, **kwargs):
        raise job.RenderFailed("stopped here")
    monkeypatch.setattr(job, "render_scene", stopped)
    assert main(["render", str(src), "--size", "8x6", "-o", str(tmp_path / "s.png")]) == 1
    err = capsys.readouterr().err
    said = err.index("nothing is bounded, so every ray walks all the instances it meets")
    assert said < err.index("stopped here") and err.count("nothing is bounded") == 1
