"""The graph as flat numpy arrays: the only form the numba kernels see."""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..language.names import FRACTAL_PRIMITIVES, PRIMITIVES
from ..trace.fractals import ARG_WIDTH, fractal_row
from ..trace.instance_table import row_fields
from ..trace.native import MIN_ROWS, native_blocks
from ..trace.transforms import CODES as TRANSFORM_CODES
from ..trace.transforms import affine
from ..trace.transforms import matrix as transform_matrix
from ..trace.vm import RAND, SALT, STORE
from .defer import deferrable
from .linear import invertible
from .model import CALC, MATERIAL, PAINT, PRIMITIVE, SELECT, TRANSFORM, Graph
from .operand_trees import operand_trees
from .peephole import fuse_operands
from .terminating import terminating_rules

NORMAL_DECAY = 0.85     # a graftal hit's normal: each coarser box weighs 0.85 of the next
HOLD_SLACK = 256        # a rule's box within 1/256 of its S-node's on every side is not tested
CACHED_CALC_ROWS = 24   # blocks at least this long are worth a cache lookup (nodes.cached_calc)

Flat = namedtuple("Flat", [
    "kind",          # int8[n]      node kind (model.SELECT ...)
    "code",          # int32[n]     transformation, primitive or material code; -1
    "child_start",   # int32[n]     into `children`
    "child_count",   # int32[n]
    "children",      # int32[m]
    "expr_start",    # int32[n]     into `expr_ids`
    "expr_count",    # int32[n]
    "expr_ids",      # int32[k]     selection | arguments | assigned values
    "term_rule",     # int32[n]     S-nodes: the rule that ends soonest, -1 if none
    "fixed",         # int8[n]      T- and paint nodes whose arguments are constants, and
                     #              material nodes with a colour of their own: 1, with
    "fixed_map",     # float64[n,24]  [L (9) | t (3) | L^-1 (9) | unused (3)], row-major;
                     #                paint and material: [r, g, b | unused]
    "then",          # int32[n]     T-nodes: the T-node below whose map they compose with
                     #              their own at run time (_compose_chains), -1: none
    "origin",        # int32[n]     a `matrix` node written for a run (graph/fuse.py): the
                     #              run's head, whose maps name a bad one; -1: none
    "box",           # float64[n,6] hyper-bounding box in the node's input frame
    "sphere",        # float64[n,4] (centre, radius) bounding a graftal S-node instead of its
                     #              box where that is smaller (radius < 0: the box); [0,4]
                     #              when no node has one (graph/volumes.py)
    "fractal",       # float64[n,5] fractal primitives: arguments, bounding radius
    "tree_root",     # int32[n]     unions of many operands: the first row of the tree of
                     #              boxes over their operands (graph/operand_trees.py), -1: none
    "tree_box",      # float64[b,6] per tree row: the box of its operands
    "tree_skip",     # int32[b]     the row after its subtree
    "tree_first",    # int32[b]     leaves: their operands are tree_items[first:first + count]
    "tree_count",    # int32[b]     (0: an inner row)
    "tree_items",    # int32[k]     operand numbers
    "inst_keys",     # uint64[s]    instance table: S-node instance hash (0: empty) ->
    "inst_used",     # int16[s]     0: empty, else the entry's level + 1 (not probed)
    "inst_boxes",    # float32[s,8] that instance's own box (top levels only); keys and
                     #              boxes are views of one array (instance_table.tracer_rows)
    "inst_deepest",  # int64        the deepest level the table keeps (-1: none)
    "by_state",      # int64        1: the table is a memoised system's, keyed by state
                     #              (graph/states.py), not by instance hash
    "state_start",   # int32[n]     S-nodes keyed by state: their key's slots in
    "state_count",   # int32[n]       state_slots (count -1: the node has no entries)
    "state_slots",   # int32[k]
    "vm_code",       # int32[q,2]   expression bytecode
    "vm_consts",     # float64[c]
    "vm_start",      # int32[e]     per expression
    "vm_end",        # int32[e]
    "calc_start",    # int32[n]     C-nodes: their block as one program in vm_code
    "calc_end",      # int32[n]
    "calc_cache",    # int8[n]      C-nodes whose results the walk caches (long blocks)
    "calc_fn",       # int64[n]     C-nodes: the address of the callback that runs their
                     #              compiled block, 0: none (trace/native.py)
    "arg_fn",        # int64[n]     T- and paint nodes with arguments that are not constants:
                     #              their arguments compiled as one block that stores them in
                     #              the parameter columns from arg_base on (nodes.eval_args);
                     #              S-nodes: their selection, into arg_base (nodes.pick_rule)
    "block_no",      # int64[n]     the number of that block in the callback
    "defer",         # int8[n]      C- and paint nodes the first-hit walks leave to a hit
                     #              (graph/defer.py)
    "chain",         # int8[n]      1: the node heads a run of single-child steps (C-, T-,
                     #              paint, material nodes) that ends in a primitive, 2: in a
                     #              fractal (which the tracer marches: not a cheap operand)
    "holds",         # int8[m]      per entry of `children`: 1 where it is a rule of an
                     #              S-node and its box holds the S-node's (_holds)
    "cheap",         # int8[m]      per entry of `children`: 1 where the child is a primitive
                     #              or heads a chain to one, not a fractal (the walks visit
                     #              such operands of a union first: nodes.cheap_operand)
    "root",          # int64
    "n_params",      # int64        the system's parameters, then arg_base's columns
    "arg_base",      # int64        the first column of compiled arguments (scratch)
    "max_stack",     # int64        expression stack depth
    "max_children",  # int64
    "hashed",        # int64        1 if anything reads instance hashes (rand(), the table)
    "pixels_slot",   # int64        the parameter slot of `pixels`, -1 if no selection reads it
    "normal_decay",  # float64      weight of a coarser box in a graftal hit's averaged normal
                     #              (0: no module is a graftal, or the box normal alone)
])


def _flat_again(fields):
    """A pickled or copied Flat: inst_keys a view of the rows again (row_fields), not the
    contiguous array pickle makes of it, which is another type to numba: every kernel
    compiled again for the copy, minutes without a word (QA: pickle.loads(pickle.dumps(
    pcsg.loads("sphere"))).trace(...) took 3.5 minutes)."""
    flat = Flat(*fields)
    return flat._replace(inst_keys=row_fields(flat.inst_boxes, flat.inst_used)["inst_keys"])


Flat.__reduce__ = lambda self: (_flat_again, (tuple(self),))


def flatten_graph(graph: Graph, boxes: np.ndarray, table: dict | None = None,
                  normal_decay: float = NORMAL_DECAY, spheres=None, states=None,
                  native_args: bool = False, runs: bool = True) -> Flat:
    """`table`: the instance table's rows (instance_table.tracer_rows); keyed by state where
    `states` gives each node's key slots (graph/states.py; None: not keyed). With
    `native_args`, the arguments of T- and paint nodes and the selections of S-nodes are
    compiled too (Flat.arg_fn): for the systems bounded instance by instance, whose walks
    visit millions of instances; a system bounded by its states would pay their load
    (4 ms for the tree's arguments) for nothing. With `runs`, a run of T-nodes is
    entered as one (_compose_chains), as the tracer does; the bounding walk does without
    (trace/boxwalk.py)."""
    nodes = graph.nodes
    n = len(nodes)
    kind = np.array([x.kind for x in nodes], dtype=np.int8)
    code = np.full(n, -1, dtype=np.int32)
    for i, x in enumerate(nodes):
        if x.kind == TRANSFORM:
            code[i] = TRANSFORM_CODES[x.name]
        elif x.kind == PRIMITIVE:
            code[i] = PRIMITIVES.index(x.name)
        elif x.kind == MATERIAL:
            code[i] = graph.material_names.index(x.name)
    counts = np.array([len(x.children) for x in nodes], dtype=np.int32)
    ecounts = np.array([len(x.exprs) for x in nodes], dtype=np.int32)
    term = np.full(n, -1, dtype=np.int32)
    for s, r in terminating_rules(graph).items():
        term[s] = r
    vm = graph.exprs.arrays()
    fixed, fixed_map = _fixed_nodes(graph)
    dynamic = np.isin(kind, (TRANSFORM, PAINT)) & (fixed == 0)
    with_args = (dynamic | (kind == SELECT)) & (ecounts > 0) & native_args
    arg_base = len(graph.params)
    # scratch columns after the parameters: as many as a node stores (a selection: one)
    scratch = int(np.where(kind == SELECT, 1, ecounts)[with_args].max(initial=0))
    vm_code, prog_start, prog_end = calc_programs(graph, vm, with_args, arg_base)
    is_calc = kind == CALC
    programs = is_calc | with_args
    vm_code, remap = fuse_operands(vm_code, np.concatenate([vm["start"], prog_start[programs]]))
    vm_start = remap[np.asarray(vm["start"], dtype=np.int64)].astype(np.int32)
    vm_end = remap[np.asarray(vm["end"], dtype=np.int64)].astype(np.int32)
    prog_start = np.where(programs, remap[prog_start], 0).astype(np.int32)
    prog_end = np.where(programs, remap[prog_end], 0).astype(np.int32)
    calc_start = np.where(is_calc, prog_start, 0)
    calc_end = np.where(is_calc, prog_end, 0)
    calc_cache = (calc_end - calc_start >= CACHED_CALC_ROWS).astype(np.int8)
    # short blocks cost little more on the machine than a call, but a node's arguments
    # are one call instead of one run of the machine per argument
    blocks = {int(i): (int(prog_start[i]), int(prog_end[i])) for i in np.flatnonzero(programs)
              if with_args[i] or prog_end[i] - prog_start[i] >= MIN_ROWS}
    compiled, block_no = native_blocks(vm_code, blocks, n)
    calc_fn = np.where(is_calc, compiled, 0)
    arg_fn = np.where(with_args, compiled, 0)
    if table is None:
        table = row_fields()
    fractal = np.zeros((n, ARG_WIDTH))
    is_fractal = np.zeros(n, dtype=bool)
    for i, x in enumerate(nodes):
        if x.kind == PRIMITIVE and x.name in FRACTAL_PRIMITIVES:
            fractal[i] = fractal_row(x.name, graph.constant_args(i))
            is_fractal[i] = True
    children = np.array([c for x in nodes for c in x.children], dtype=np.int32)
    state_count = np.full(n, -1, dtype=np.int32)
    keyed = [np.zeros(0, dtype=np.int32)] * n
    for i, slots in enumerate(states or []):
        if slots is not None:
            keyed[i] = np.asarray(slots, dtype=np.int32)
            state_count[i] = len(slots)
    starts = _starts(counts)
    _compose_fixed_chains(kind, fixed, fixed_map, starts, children)
    defer = deferrable(graph, fixed)
    then = (_compose_chains(kind, starts, children) if runs
            else np.full(n, -1, dtype=np.int32))
    chain = _chains(kind, starts, children, is_fractal)
    origin = np.full(n, -1, dtype=np.int32)
    for m, head in graph.origins.items():
        origin[m] = head
    box = np.ascontiguousarray(boxes, dtype=np.float64)
    sphere = np.ascontiguousarray(np.zeros((0, 4)) if spheres is None else spheres,
                                  dtype=np.float64)
    return Flat(
        kind=kind, code=code,
        child_start=starts, child_count=counts,
        children=children,
        expr_start=_starts(ecounts), expr_count=ecounts,
        expr_ids=np.array([e for x in nodes for e in x.exprs], dtype=np.int32),
        term_rule=term, fixed=fixed, fixed_map=fixed_map, then=then, origin=origin,
        box=box, fractal=fractal, sphere=sphere,
        **operand_trees(kind, starts, counts, children, box, sphere),
        **table,
        by_state=np.int64(states is not None), state_count=state_count,
        state_start=_starts(np.maximum(state_count, 0)),
        state_slots=np.concatenate([np.zeros(0, dtype=np.int32), *keyed]),
        vm_code=vm_code, calc_start=calc_start, calc_end=calc_end, calc_cache=calc_cache,
        calc_fn=calc_fn, arg_fn=arg_fn, block_no=block_no, arg_base=np.int64(arg_base),
        defer=defer, chain=chain, holds=_holds(kind, starts, counts, children, boxes, spheres),
        cheap=((chain[children] == 1) | ((kind[children] == PRIMITIVE)
                                          & ~is_fractal[children])).astype(np.int8),
        vm_consts=np.asarray(vm["consts"], dtype=np.float64),
        vm_start=vm_start, vm_end=vm_end,
        root=np.int64(graph.root),
        n_params=np.int64(max(1, arg_base + scratch)),
        max_stack=np.int64(max(1, vm["max_stack"])),
        max_children=np.int64(max(1, counts.max(initial=1))),
        hashed=np.int64((len(table["inst_keys"]) > 2 and states is None)
                        or bool(np.any(vm["code"][:, 0] == RAND))
                        or bool(calc_cache.any())),
        pixels_slot=np.int64(graph.pixels),
        normal_decay=np.float64(normal_decay if any(
            graph.nodes[s].kind == SELECT and term[s] < 0 for s in range(n)) else 0.0),
    )


def calc_programs(graph: Graph, vm: dict, with_args=None, arg_base: int = 0):
    """vm's code with every C-node's assignments appended as one program (see vm.py), and
    the arguments of the nodes `with_args` (an S-node's: its selection) as one program that
    stores argument k into parameter column arg_base + k, each drawing rand() from the
    salt that eval_args (pick_rule) gives it; returns the code and each node's program rows
    (empty for other nodes)."""
    code = np.asarray(vm["code"], dtype=np.int32).reshape(-1, 2)
    n = len(graph.nodes)
    start = np.zeros(n, dtype=np.int32)
    end = np.zeros(n, dtype=np.int32)
    rows = [code]
    top = len(code)
    for i, node in enumerate(graph.nodes):
        exprs, first_salt = node.exprs, 1
        if node.kind == CALC:
            targets = node.targets
        elif with_args is not None and with_args[i]:
            if node.kind == SELECT:
                exprs, first_salt = node.exprs[:1], 0
            targets = [arg_base + k for k in range(len(exprs))]
        else:
            continue
        start[i] = top
        for k, (e, target) in enumerate(zip(exprs, targets)):
            body = code[vm["start"][e]:vm["end"][e]]
            if np.any(body[:, 0] == RAND):
                rows.append(np.array([[SALT, k + first_salt]], dtype=np.int32))
                top += 1
            rows += [body, np.array([[STORE, target]], dtype=np.int32)]
            top += len(body) + 1
        end[i] = top
    return np.ascontiguousarray(np.concatenate(rows)), start, end


def _fixed_nodes(graph: Graph):
    """Matrices and inverses of the T-nodes whose arguments folded to constants, and
    the colours of such paint nodes, computed once here instead of once per ray and
    visit. Singular or non-finite ones stay dynamic so that the walk reports them."""
    n = len(graph.nodes)
    fixed = np.zeros(n, dtype=np.int8)
    maps = np.zeros((n, 24))
    for i, node in enumerate(graph.nodes):
        if node.kind == PAINT:
            args = [graph.exprs.constant(e) for e in node.exprs]
            if all(a is not None for a in args) and np.isfinite(args).all():
                fixed[i] = 1
                maps[i, :3] = args
            continue
        if node.kind == MATERIAL:
            # notation §8: of paint and material the innermost colours, so a material
            # with a color= of its own paints over the paint above it
            if node.name in graph.scene.coloured:
                fixed[i] = 1
                maps[i, :3] = graph.scene.materials[node.name]["color"]
            continue
    ids, m = fixed_maps(graph)
    lin = m[:, :, :3]
    fixed[ids] = 1
    maps[ids, :9] = lin.reshape(-1, 9)
    maps[ids, 9:12] = m[:, :, 3]
    maps[ids, 12:21] = np.linalg.inv(lin).reshape(-1, 9)
    return fixed, maps


def fixed_maps(graph: Graph) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, (k, 3, 4) maps): the T-nodes that fixed_matrix gives a matrix, tested and
    inverted as one stack: one numpy call a node took 8 of the 20 s that an expanded
    Sierpinski at 7 (160,000 maps) spent on its bounds."""
    ids, args = [], []
    for i, node in enumerate(graph.nodes):
        if node.kind == TRANSFORM:
            a = [graph.exprs.constant(e) for e in node.exprs]
            if all(x is not None for x in a):
                ids.append(i)
                args.append(np.asarray(a, dtype=np.float64).reshape(-1) if a else np.zeros(1))
    m = np.empty((len(ids), 3, 4))
    for k, i in enumerate(ids):
        affine(TRANSFORM_CODES[graph.nodes[i].name], args[k], m[k])
    ok = invertible(m)
    return np.asarray(ids, dtype=np.int64)[ok], m[ok]


def fixed_matrix(graph: Graph, i: int) -> np.ndarray | None:
    """The 4x4 matrix of T-node i where its arguments folded to constants and it is
    finite and invertible; None otherwise (a T-node that the walk evaluates, and reports
    where singular)."""
    node = graph.nodes[i]
    if node.kind != TRANSFORM:
        return None
    args = [graph.exprs.constant(e) for e in node.exprs]
    if any(a is None for a in args):
        return None
    m = transform_matrix(node.name, args)
    return m if invertible(m[:3]) else None


def _compose_fixed_chains(kind, fixed, maps, starts, children):
    """A fixed T-node whose child is a fixed T-node takes the composed map and points past
    it (move(...) uscale(0.5) S: one map, one box test and one ray transform per visit).
    The skipped node stays in place for any other parent."""
    changed, composed = True, set()
    while changed:
        changed = False
        for i in np.nonzero(fixed)[0]:
            if kind[i] != TRANSFORM:
                continue
            c = children[starts[i]]
            if kind[c] != TRANSFORM or not fixed[c]:
                continue
            a = _affine4(maps[i])
            b = _affine4(maps[c])
            m = a @ b
            maps[i, :9] = m[:3, :3].ravel()
            maps[i, 9:12] = m[:3, 3]
            composed.add(int(i))
            children[starts[i]] = children[starts[c]]
            changed = True
    # the inverses of the composed maps at the end, as one stack: a chain's inverses on
    # the way are never read (one numpy call each took 2 s of an expanded Sierpinski's
    # bounds at 7)
    done = np.array(sorted(composed), dtype=np.int64)
    maps[done, 12:21] = np.linalg.inv(maps[done, :9].reshape(-1, 3, 3)).reshape(-1, 9)


def _compose_chains(kind, starts, children):
    """A T-node whose child is a T-node (one of them computed from parameters; fixed
    pairs are composed above) composes the child's map with its own when it is entered
    (nodes.composed_affine) and points past it: the terrain's final `move(0,0,z1)
    zshear(...)` is one frame and one ray transform per ray instead of two. The skipped
    node stays in place for any other parent, and itself composes what is below it.
    Returns `then`."""
    below = np.full(len(kind), -1, dtype=np.int32)
    for i in np.flatnonzero(kind == TRANSFORM):
        c = children[starts[i]]
        if kind[c] == TRANSFORM:
            below[i] = c
    then = np.full(len(kind), -1, dtype=np.int32)
    past = {}
    for i in np.flatnonzero(below >= 0):
        seen, c = {int(i)}, int(below[i])
        while below[c] >= 0 and c not in seen:
            seen.add(c)
            c = int(below[c])
        if below[c] < 0:        # else a cycle of T-nodes alone, which no rule makes
            then[i] = below[i]
            past[int(i)] = children[starts[c]]
    for i, c in past.items():
        children[starts[i]] = c
    return then


def _chains(kind, starts, children, fractal):
    """Flat.chain: a terminating rule is mostly such a run (calc paint move ... primitive),
    which the bounding walk takes in one step instead of a frame per node; the tracers
    visit a union's operands that are such runs first (nodes.cheap_operand)."""
    steps = np.isin(kind, (CALC, TRANSFORM, PAINT, MATERIAL))
    step = steps.tolist()
    # a step's one child (a primitive's start may be past the end of `children`)
    first = np.where(steps, children[np.minimum(starts, max(len(children) - 1, 0))]
                     if len(children) else -1, -1).tolist()
    # where each step's run ends: a node that is no step, or -1 (a cycle of steps); each
    # run is followed once (from each of its nodes in turn, 5,000 C-nodes took 6 s)
    UNKNOWN = -2
    end = [UNKNOWN] * len(kind)
    for i in np.flatnonzero(steps).tolist():
        path, node = [], i
        while step[node] and end[node] == UNKNOWN:
            end[node] = -1              # on the path: met again, a cycle
            path.append(node)
            node = first[node]
        last = end[node] if step[node] else node
        for p in path:
            end[p] = last
    chain = np.zeros(len(kind), dtype=np.int8)
    for i in np.flatnonzero(steps).tolist():
        if end[i] >= 0 and kind[end[i]] == PRIMITIVE:
            chain[i] = 2 if fractal[end[i]] else 1
    return chain


def _affine4(row):
    m = np.eye(4)
    m[:3, :3] = row[:9].reshape(3, 3)
    m[:3, 3] = row[9:12]
    return m


def _holds(kind, starts, counts, children, boxes, spheres) -> np.ndarray:
    """Which rules' boxes hold their S-node's box, but for slivers: each of its sides
    is the S-node's or lies at most 1/HOLD_SLACK of the S-node's extent inside. A ray's
    window at such a rule is inside the S-node's box, so inside the rule's or nearly, and
    the walks do not test the rule's box: it would cull a sliver at most, and skipping a
    box only ever costs work, since it bounds what lies below. A union that subdivides
    has the box of its S-node (the terrain's T1), or all but a hair of it (T2 at order 9:
    its union's top is 1e-4 under the highest final triangle's). Not where either is
    bounded by a sphere, which a window inside the box may leave."""
    holds = np.zeros(len(children), dtype=np.int8)
    boxes = np.asarray(boxes, dtype=np.float64)
    round_ = np.zeros(len(kind), dtype=bool)
    if spheres is not None and len(spheres):
        round_ = np.asarray(spheres)[:, 3] >= 0.0
    for s in np.flatnonzero(kind == SELECT):
        lo, hi = boxes[s, :3], boxes[s, 3:]
        if np.any(lo > hi) or round_[s]:
            continue
        extent = hi - lo
        slack = np.where(np.isfinite(extent), extent / HOLD_SLACK, 0.0)
        for e in range(starts[s], starts[s] + counts[s]):
            c = children[e]
            holds[e] = (not round_[c] and bool(np.all(boxes[c, :3] <= lo + slack))
                        and bool(np.all(boxes[c, 3:] >= hi - slack)))
    return holds


def _starts(counts: np.ndarray) -> np.ndarray:
    out = np.zeros(len(counts), dtype=np.int32)
    if len(counts) > 1:
        out[1:] = np.cumsum(counts[:-1])
    return out

