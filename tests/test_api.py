"""The Python API's arguments: what a program embedding pcsg gets for wrong ones (clear
exceptions, not a silent miss or a message from deep inside), and parameters named like
an argument of load/loads."""
import numpy as np
import pytest

import pcsg

from .conftest import GRAMMARS


@pytest.mark.parametrize("option", [dict(tmin=float("nan")), dict(tmax=float("nan")),
                                    dict(lod=-1.0), dict(lod=float("nan")), dict(tmin="1"),
                                    dict(cone=-1.0), dict(cone=float("inf")),
                                    dict(cone=[0.0, 0.0]), dict(cone="wide"), dict(cone="1"),
                                    dict(cone=True), dict(any_hit="False"),
                                    dict(packets="no"), dict(any_hit=2)])
def test_trace_refuses_bounds_and_footprints_that_are_no_numbers(option):
    # tmin or tmax nan made every ray miss; a negative lod was taken as 0
    obj = pcsg.loads("sphere")
    with pytest.raises(ValueError, match=f"^{next(iter(option))}="):
        obj.trace([0, 0, -5], [0, 0, 1], **option)
    assert obj.trace([0, 0, -5], [0, 0, 1], tmin=np.float32(0.5), lod=np.float64(1e-3)).t == 4
    # a width each ray starts with (a secondary ray's), or one for all
    assert obj.trace([[0, 0, -5]] * 2, [[0, 0, 1]] * 2, lod=1e-3, cone=[0.0, 0.01]).hit.all()


@pytest.mark.parametrize("args, option, said", [
    (([0, 0, -5], [0, 0, 1]), dict(tmax=-1), "tmin=1e-09, tmax=-1: the hits are sought for "
                                             "tmin < t < tmax, so tmax must be greater"),
    (([0, 0, -5], [0, 0, 1]), dict(tmin=5, tmax=1), "tmin=5, tmax=1: "),
    (([0, 0, -5], [0, 0, 0]), {}, r"directions: ray 0 has direction \(0.0, 0.0, 0.0\)"),
    (([[0, 0, -5], [0, 0, float("nan")]], [[0, 0, 1]] * 2), {},
     r"origins: ray 1 starts at \(0.0, 0.0, nan\): give finite"),
    (([0, 0, -5], [float("inf"), 0, 1]), {}, "directions: ray 0 has direction"),
    # no rays of the wrong shape were taken as none
    ((np.empty((0, 5)), np.empty((0, 5))), {}, r"origins must be real numbers of shape"),
    ((np.empty((5, 0)), np.empty((5, 0))), {}, r"origins must be real numbers of shape"),
    ((np.ma.masked_array([[0, 0, -5]], mask=[[0, 0, 1]]), [[0, 0, 1]]), {},
     "origins has masked entries"),
])
def test_trace_refuses_rays_that_could_only_miss(args, option, said):
    """Traced as misses without a word (QA of the README's claim)."""
    obj = pcsg.loads("sphere")
    with pytest.raises(ValueError, match=f"^{said}"):
        obj.trace(*args, **option)


@pytest.mark.parametrize("text, said", [(b"sphere", "got bytes (decode it first)"),
                                        (None, "got NoneType")])
def test_loads_takes_text(text, said):
    with pytest.raises(TypeError) as e:
        pcsg.loads(text)
    assert str(e.value).endswith(said)


@pytest.mark.parametrize("value", ["abc", "3", True, None, [1]])
def test_a_parameter_is_a_number(value):
    # "could not convert string to float", without the parameter's name; "3" was taken
    with pytest.raises(TypeError) as e:
        pcsg.loads("{c = 1} uscale(c) sphere", c=value)
    assert str(e.value) == f"parameter c={value!r}: give a number"


def test_parameters_named_like_an_argument_go_in_params():
    # file=3 named the text in messages, max_depth=4 was the walk's depth
    obj = pcsg.loads("{file = 1; max_depth = 2} move(file, max_depth, 0) sphere",
                     params={"file": 3, "max_depth": 4})
    np.testing.assert_allclose(obj.bounds, [2, 3, -1, 4, 5, 1])
    obj = pcsg.loads("{c = 1; d = 1} scale(c, d, 1) sphere", params={"c": 2}, d=3)
    np.testing.assert_allclose(obj.bounds, [-2, -3, -1, 2, 3, 1])


def test_a_parameter_given_twice_is_refused():
    """The keyword won and params' value was dropped unsaid; --set c=1 --set c=2 is
    refused, and so is a Python call given the same keyword twice."""
    with pytest.raises(ValueError, match="^parameter c is given twice, in params and as a "
                                         "keyword argument: give it once$"):
        pcsg.loads("{c = 1} uscale(c) sphere", params={"c": 2}, c=3)
    with pytest.raises(ValueError, match="given twice"):
        pcsg.load(GRAMMARS / "sierpinski.pcsg", params={"c": 3}, c=4)


@pytest.mark.parametrize("file", [3, None, b"name"])
def test_loads_file_is_a_name(file):
    """loads(text, file=3) named the text "3" in its errors: a parameter named file was
    meant, which goes in params."""
    with pytest.raises(TypeError, match=r"^file=.*: loads takes the name its errors give"):
        pcsg.loads("{file = 1} uscale(file) sphere", file=file)


@pytest.mark.parametrize("value, want", [(np.array(2.0), 2), (np.float32(2), 2), (2, 2)])
def test_numpy_numbers_are_numbers(value, want):
    assert pcsg.loads("{c = 1} uscale(c) sphere", c=value).bounds[3] == want
    assert pcsg.loads("sphere", max_depth=np.float32(10)).max_depth == 10


def test_what_cannot_be_a_float_is_said():
    with pytest.raises(ValueError, match="too large for a float"):
        pcsg.loads("{c = 1} uscale(c) sphere", c=10 ** 400)
    with pytest.raises(TypeError, match="give a number"):
        pcsg.loads("{c = 1} uscale(c) sphere", c=1 + 2j)
    for value in (float("nan"), float("inf"), -np.inf):     # --set refuses them too
        with pytest.raises(ValueError, match="give a finite number"):
            pcsg.loads("{c = 1} uscale(c) sphere", c=value)
    with pytest.raises(ValueError, match="use a whole number, 1 to 10000"):
        pcsg.loads("sphere", max_depth=10.5)


def test_an_unknown_parameter_is_said_without_the_command_lines_option():
    # the API's user gave k=2, not --set k=2
    with pytest.raises(pcsg.PcsgError) as e:
        pcsg.loads("{c = 6} sphere", k=2)
    message = e.value.diagnostics[0].message
    assert message == "cannot set 'k': it is not an initial parameter (initial parameters: c)"


def test_what_a_hit_is_an_integer_code():
    hits = pcsg.loads("sphere").trace([[0, -5, 0]], [[0, 1, 0]])
    assert hits.what.dtype == np.int64 and hits.what.tolist() == [1]


@pytest.mark.parametrize("events", [np.zeros(3), None, np.zeros((2, 2), dtype=np.int64)])
def test_describe_events_says_what_it_takes(events):
    obj = pcsg.loads("sphere")
    with pytest.raises(ValueError, match=r"events: give an array a trace counted"):
        obj.describe_events(events)
    assert obj.describe_events(obj.trace([[0, -5, 0]], [[0, 1, 0]]).events) == []


def test_origins_and_directions_that_differ_are_said_as_given():
    obj = pcsg.loads("sphere")
    with pytest.raises(ValueError, match=r"^origins \(3,\) and directions \(2, 3\) differ: "
                                         r"give one origin per direction"):
        obj.trace([1, 2, 3], [[1, 0, 0], [0, 1, 0]])
    shared = np.broadcast_to([0.0, -5.0, 0.0], (2, 3))     # what the message says works
    assert obj.trace(shared, [[0, 1, 0], [0, 1, 0.01]]).hit.all()


def test_no_rays_are_no_hits():
    obj = pcsg.loads("sphere")
    for none in ([], np.empty((0, 3))):
        assert len(obj.trace(none, none).t) == 0


def test_params_is_a_mapping():
    for params in ([("c", 2)], "c=2"):
        with pytest.raises(TypeError, match=r"^params=.*: give a dict of parameter names"):
            pcsg.loads("{c = 1} uscale(c) sphere", params=params)


def test_describe_events_names_the_apis_arguments_and_takes_event_numbers():
    """Its lines told the API's user to raise --max-instances and --max-depth."""
    from pcsg.trace.nodes import EV_DEPTH, EV_VISITS
    obj = pcsg.load(GRAMMARS / "sierpinski.pcsg", c=6, max_instances=1)
    h = obj.trace([[0.1, -5, 0.3]], [[0, 1, 0]])
    (line,) = obj.describe_events(h.events)
    assert "after entering max_instances=1 instances" in line
    assert line.endswith("raise max_instances to go on") and "--" not in line
    deep = pcsg.load(GRAMMARS / "sierpinski.pcsg", c=6, max_depth=2)
    h = deep.trace([[0.1, -5, 0.3]], [[0, 1, 0]])
    (line,) = deep.describe_events(h.events, kinds=[EV_DEPTH])
    assert "instances at max_depth=2 were finished" in line and "raise max_depth to" in line
    assert deep.describe_events(h.events, kinds=[EV_VISITS]) == []
    for kinds in ("depth", 5, [99]):
        with pytest.raises(ValueError, match=r"^kinds=.*: give event numbers from 0 to 7"):
            deep.describe_events(h.events, kinds=kinds)


def test_bounds_is_a_copy():
    obj = pcsg.loads("sphere")
    obj.bounds[:] = 0
    assert obj.bounds.tolist() == [-1, -1, -1, 1, 1, 1]


def test_a_path_like_is_a_path(tmp_path):
    src = tmp_path / "ball.pcsg"
    src.write_text("sphere\n", encoding="utf-8")

    class Named:
        def __fspath__(self):
            return str(src)
    assert pcsg.load(Named()).bounds.tolist() == [-1, -1, -1, 1, 1, 1]


def test_a_copied_object_traces_with_the_same_kernels():
    """A pickled or copied object's instance keys were a contiguous array, where the
    original's are a view of the table's rows: another type to numba, every kernel compiled
    again for it (3.5 minutes, QA)."""
    import copy
    import pickle
    import numba
    obj = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=4)
    o, d = np.array([[0.3, 0.4, 2.0]]), np.array([[0.01, 0.02, -1.0]])
    for other in (pickle.loads(pickle.dumps(obj)), copy.deepcopy(obj)):
        assert [numba.typeof(a) for a in other.flat] == [numba.typeof(a) for a in obj.flat]
        assert np.shares_memory(other.flat.inst_keys, other.flat.inst_boxes)
        assert np.array_equal(other.trace(o, d).t, obj.trace(o, d).t)


def test_a_graftal_traced_without_a_level_of_detail_is_told_to_take_one():
    """Traced with lod=0, the fern is a dust of boxes at max_depth 64 that the rays
    missed (10 hits of 2,000 where lod=1e-3 had 568), and the depth limit's line said to
    raise max_depth, which makes a finer dust."""
    from pcsg.limits import cli_option
    from pcsg.trace.nodes import EV_DEPTH
    fern = pcsg.load(GRAMMARS / "barnsley_fern.pcsg")
    eye = np.array([11.0, -16.0, 5.0])
    aim = np.random.default_rng(1).normal(size=(2000, 3)) * [1.5, 0.5, 2.5] + [0.4, 0.4, 5.3]
    d = aim - eye
    h = fern.trace(np.broadcast_to(eye, d.shape), d / np.linalg.norm(d, axis=1)[:, None])
    (line,) = fern.describe_events(h.events, kinds=[EV_DEPTH])
    assert "a trace with lod=0 meets a dust of boxes" in line
    assert line.endswith("; else raise max_depth to refine further")
    # the command line always traces with the pixel's angle: no lod= to give there
    (said,) = fern.describe_events(h.events, kinds=[EV_DEPTH], option=cli_option)
    assert "lod" not in said and said.endswith("raise --max-depth to refine further")
    # a system whose rules end is refined by a deeper limit
    deep = pcsg.load(GRAMMARS / "sierpinski.pcsg", c=6, max_depth=2)
    (line,) = deep.describe_events(deep.trace([[0.1, -5, 0.3]], [[0, 1, 0]]).events)
    assert "lod" not in line


def test_warnings_name_the_limits_as_load_takes_them():
    """They said "to --max-depth 64: a smaller --max-depth (16, say)" to a Python caller,
    where describe_events says `max_depth=` (QA)."""
    import pcsg
    obj = pcsg.loads("S\nS 1\n1: S → S ∪ move(0.1,0,0) S ∪ sphere")
    said = " ".join(w.message for w in obj.warnings)
    assert "bounds_budget=400,000,000 node visits" in said and "to max_depth=64" in said
    assert "a smaller max_depth (16, say)" in said and "--" not in said
