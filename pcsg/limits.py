"""Defaults and bounds of the walk's fixed-capacity buffers, in a module without numba
so that the command line can name them in its help without loading the kernels."""
import math
import operator

MAX_DEPTH = 64                  # derivation levels a ray may descend (--max-depth)
DEEPEST_DEFAULT = 1_000         # without --max-depth, a derivation that ends (memoised) is
                                # walked as deep as it goes, up to this: a row of 100 trees
                                # written as a chain ended at 64
INTERVAL_ROWS = 4096            # interval-list rows per worker (--interval-rows)
MAX_INSTANCES = 1 << 16         # S-node instances one ray may enter (--max-instances): a
                                # system that neither ends nor contracts stops there, not
                                # after 2^64 instances; the samples need at most a few
                                # hundred per ray
BOUNDS_BUDGET = 400_000_000     # node visits of the bounding walk (--bounds-budget), about
                                # 5 s on two cores, enough for the terrain at 12 (313
                                # million): past it the boxes stop at the deepest derivation
                                # depth whose instances fit (trace/boxwalk.py)
MAX_BOUNCES = 32                # --bounces at most: reflection and refraction depth
MAX_SAMPLES = 1024              # --samples at most
MAX_SHADOW_SAMPLES = 256        # --shadow-samples at most
MAX_STACK_DEPTH = 100_000       # --stack-depth at most: ~40 MB of frames per worker
MAX_DEPTH_ASKED = 10_000        # --max-depth at most
MAX_INTERVAL_ROWS = 1_000_000   # --interval-rows at most: 128 MB per worker
GIF_FPS = 50                   # animate --gif: frame delays of whole hundredths, 2 at least
MAX_FRAMES = 10_000             # animate --frames at most: 17 minutes at 10 fps (100,000
                                # planned for 27 s in silence, at 500 MB)
GIF_PIXELS = 500_000_000        # animate --gif: frames x width x height at most, all held in
                                # memory as Pillow quantizes them (about 5 bytes a pixel)
# the kernels take the three as one array: limits[LIM_STACK], ...
LIM_STACK, LIM_ROWS, LIM_INSTANCES = 0, 1, 2


def size_problem(size: tuple[int, int]) -> str | None:
    """The usage message for a --size without pixels (render, animate and export)."""
    w, h = size
    if w < 1 or h < 1:
        return f"--size {w}x{h}: width and height must be at least 1"
    return None


def shadow_samples_problem(samples: int) -> str | None:
    """The usage message for a --shadow-samples out of range (render, animate and export)."""
    if not 1 <= samples <= MAX_SHADOW_SAMPLES:
        return f"--shadow-samples {samples}: use 1 to {MAX_SHADOW_SAMPLES}"
    return None


def bounces_problem(bounces: int) -> str | None:
    """The usage message for a --bounces out of range (render, animate and export)."""
    if not 0 <= bounces <= MAX_BOUNCES:
        return f"--bounces {bounces}: use 0 (off) to {MAX_BOUNCES}"
    return None


def cli_option(name: str) -> str:
    """A limit as the command line gives it, before its value: `--max-depth `."""
    return "--" + name.replace("_", "-") + " "


def api_argument(name: str) -> str:
    """A limit as the Python API takes it, before its value: `max_depth=`."""
    return name + "="


def walk_limits_problem(max_depth, stack_depth, interval_rows, max_instances, bounds_budget,
                        option=cli_option) -> str | None:
    """The message for a limit of the walks out of range, naming it as `option` does (the
    command line's `--max-depth N`; the Python API's `max_depth=N`)."""
    checks = [("max_depth", max_depth, 1, MAX_DEPTH_ASKED, f"1 to {MAX_DEPTH_ASKED}", True),
              ("stack_depth", stack_depth, 16, MAX_STACK_DEPTH, f"16 to {MAX_STACK_DEPTH}", True),
              ("interval_rows", interval_rows, 16, MAX_INTERVAL_ROWS,
               f"16 to {MAX_INTERVAL_ROWS}", False),
              ("max_instances", max_instances, 1, 2 ** 62, "1 to 2^62", False),
              ("bounds_budget", bounds_budget, 1, 2 ** 62, "1 to 2^62 node visits", False)]
    for name, value, low, high, say, optional in checks:
        if value is None and optional:
            continue
        whole = _whole(value)
        if not low <= whole <= high:
            return f"{option(name)}{value!r}: use {'a whole number, ' if whole != whole else ''}{say}"
    return None


def _whole(value) -> float:
    """A whole number as itself (1e9 and numpy's float32(10) too), anything else as nan,
    which no range holds."""
    try:
        return operator.index(value) if not isinstance(value, bool) else math.nan
    except TypeError:
        number = real_number(value)
        return number if number is not None and number.is_integer() else math.nan


def real_number(value) -> float | None:
    """A real number (numpy's scalars and 0-d arrays too) as a float, nan for one too
    large for a float; None for anything else (a string, a bool, a complex number)."""
    import numpy as np      # here: the command line names the limits before numpy loads
    if isinstance(value, (bool, str, bytes, np.bool_)) or np.ndim(value) != 0 or \
            np.iscomplexobj(value):
        return None
    try:
        return float(value)
    except OverflowError:
        return math.nan
    except (TypeError, ValueError):
        return None
