"""numba's SSA reconstruction, each variable's rewrite visiting only the blocks that name it.

numba (0.68, `numba.core.ssa._run_ssa`) rewrites a function's IR once per variable that
is assigned more than once, and each rewrite walks every statement of every block, with
a call to logging.debug for each: statements times such variables. The walks have every
per-node step inlined into them, so that was a quarter of the kernels' compile (a
profile: 24 million statement visits and 26 million debug calls, 125 s of 483).
A rewrite changes nothing in a block whose statements do not name the variable, except
where it puts a phi node there, so here each variable visits the blocks that name it,
in numba's order, with numba's own handlers; the rest keep their statements. Every block
is copied once first, as numba's rewrite gives every block anew. The IR that comes out is
numba's, statement for statement (tests/test_compiling.py)."""
from __future__ import annotations

from collections import defaultdict

from numba.core import errors, ir, ssa
from numba.core.analysis import compute_cfg_from_blocks

from . import compiling

NUMBA_RUN_SSA = ssa._run_ssa


def run_ssa(blocks):
    """numba's `_run_ssa`: the same violators, rewritten in the same order."""
    if not blocks:
        return {}
    cfg = compute_cfg_from_blocks(blocks)
    df_plus = ssa._iterated_domfronts(cfg)
    violators = ssa._find_defs_violators(blocks, cfg)
    if violators and _shares_objects(blocks):
        return NUMBA_RUN_SSA(blocks)
    cache_list_vars = ssa._CacheListVars()
    naming = _blocks_naming(blocks, violators)
    if violators:
        # numba's rewrite gives every block anew: no block of the caller's is shared with
        # what comes out (statements are, in both)
        blocks = {label: _block(blk, list(blk.body)) for label, blk in blocks.items()}
    for varname in violators:
        labels = naming[varname]
        blocks, defmap = _fresh_vars(blocks, labels, varname)
        blocks = _fix_ssa_vars(blocks, labels, varname, defmap, cfg, df_plus,
                               cache_list_vars)
    if compute_cfg_from_blocks(blocks) != cfg:
        raise errors.CompilerError("CFG mutated in SSA pass")
    return blocks


def _blocks_naming(blocks, violators) -> dict[str, list]:
    """For each violator, the labels of the blocks whose statements name it, in the
    blocks' order. A rewrite only brings in fresh names of its own variable, so what
    names the others stays as it was found here."""
    wanted = set(violators)
    naming = defaultdict(list)
    for label, blk in blocks.items():
        names = {v.name for stmt in blk.body for v in stmt.list_vars()}
        for name in names & wanted:
            naming[name].append(label)
    return naming


def _shares_objects(blocks) -> bool:
    """Whether two statements share a statement, an expression or an expression's table
    of operands. numba's rewrite edits a copied expression's table in place and reads
    each expression's operands once, in its first pass, so where one object serves two
    statements what it makes depends on the order it visits every block in. No compile of
    pcsg's shares any; numba's own rewrite takes such IR."""
    seen = set()
    count = 0
    for blk in blocks.values():
        for stmt in blk.body:
            seen.add(id(stmt))
            count += 1
            if isinstance(stmt, ir.Assign) and isinstance(stmt.value, ir.Expr):
                seen.add(id(stmt.value))
                seen.add(id(stmt.value._kws))
                count += 2
    return len(seen) != count


def _fresh_vars(blocks, labels, varname):
    states = ssa._make_states(blocks)
    states['varname'] = varname
    states['defmap'] = defmap = defaultdict(list)
    return _rewrite(blocks, labels, states, ssa._FreshVarHandler()), defmap


def _fix_ssa_vars(blocks, labels, varname, defmap, cfg, df_plus, cache_list_vars):
    states = ssa._make_states(blocks)
    states['varname'] = varname
    states['defmap'] = defmap
    states['phimap'] = phimap = defaultdict(list)
    states['cfg'] = cfg
    states['phi_locations'] = ssa._compute_phi_locations(df_plus, defmap)
    newblocks = _rewrite(blocks, labels, states, ssa._FixSSAVars(cache_list_vars))
    for label, philist in phimap.items():
        newblocks[label].body = philist + newblocks[label].body
    return newblocks


def _rewrite(blocks, labels, states, handler):
    """numba's `_run_block_rewrite` over the blocks of `labels`, the others kept."""
    newblocks = dict(blocks)
    for label in labels:
        blk = blocks[label]
        states['label'] = label
        states['block'] = blk
        body = []
        for stmt in blk.body:
            if isinstance(stmt, ir.Assign):
                body.append(handler.on_assign(states, stmt))
            else:
                body.append(handler.on_other(states, stmt))
        newblocks[label] = _block(blk, body)
    return newblocks


def _block(blk, body):
    """A block in blk's scope and place with `body`."""
    new = ir.Block(scope=blk.scope, loc=blk.loc)
    new.body = body
    return new


def install() -> None:
    """For numba 0.68, whose `_run_ssa` this follows step by step and whose handlers it
    calls; another numba keeps its own way."""
    if compiling.numba_followed() and ssa._run_ssa is NUMBA_RUN_SSA:
        ssa._run_ssa = run_ssa
