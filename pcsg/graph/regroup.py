"""Unions regrouped for the tracer: the same object, with fewer frames and ray maps per
ray. Traced builds from a regrouped copy; check, expand and stats see the graph as
written.

- A run of T-nodes with constant arguments over a union goes into each operand, and
  down past the operand's C-nodes, which cannot change what it does. The sympodial
  tree's `move(0,0,1) rotz(gamma) ({cnt=cnt-1} rotx(alpha1) uscale(fBR1) TR ∪ ...)`
  becomes `{cnt=cnt-1} move(0,0,1) rotz(gamma) rotx(alpha1) uscale(fBR1) TR ∪ ...`,
  whose four maps the flat graph composes into one (flat._compose_fixed_chains): a ray
  that enters a sub-crown is mapped once where it was mapped twice, and every ray that
  reaches the union is mapped no more often than before.
- A union's operand that is a union of at most SPLICE operands is spliced into it:
  `SG ∪ (A ∪ B)` becomes `SG ∪ A ∪ B`, one frame and one box test fewer for a ray
  that enters A or B, up to OPERANDS operands: bigger unions stay nested, since a
  nest's boxes may spare a ray many tests (a balanced nest of unions is a hierarchy
  of boxes).

rand() and the instance table hash an instance's path: the S-nodes and unions on it,
with their node and child numbers (vm.edge_hash), while T- and C-nodes do not hash.
The first rewrite keeps every union's node and its operands' order, so every hash is
kept. The second numbers the spliced operands anew, so it is done only in systems
without rand(): their pictures do not depend on the hashes, and the instance table is
built from the regrouped graph. Nodes are rewritten in place only where nothing else
refers to them; none is renumbered (the numbers are in the hashes), so a spliced union
stays in the list, unreachable.
"""
from __future__ import annotations

from dataclasses import replace

from ..trace.vm import RAND
from .flat import fixed_maps
from .model import CALC, TRANSFORM, UNION, Graph

SPLICE = 2      # the most operands of a union spliced into the union above it
OPERANDS = 4    # and the most that union may get: a deeper nest of unions is a hierarchy


def regroup(graph: Graph) -> Graph:
    """The regrouped copy; `graph` itself is left as it is."""
    nodes = [_copy(n, list(n.children)) for n in graph.nodes]
    g = replace(graph, nodes=nodes)
    r = _Regroup(g)
    g.root = r.distribute()
    if not draws_per_instance(g):
        r.splice()
    return g


def draws_per_instance(graph: Graph) -> bool:
    """Whether some expression calls rand() without a seed, whose numbers hash each
    instance's path (operand numbers included): a rewrite that numbers operands anew
    changes its picture."""
    return bool((graph.exprs.arrays()["code"][:, 0] == RAND).any())


def _copy(node, children: list[int]):
    """A node with children of its own, its other fields shared as dataclasses.replace
    shares them: replace (which calls __init__), or copy.copy, took 2 s of the bounds of
    an expanded Sierpinski at 7 (190,000 nodes)."""
    new = object.__new__(type(node))
    new.__dict__.update(node.__dict__)
    new.children = children
    new.edge_spans = list(node.edge_spans)
    return new


class _Regroup:
    def __init__(self, g: Graph):
        self.g = g
        # the T-nodes whose maps are constant (of the nodes so far: a run's copies are
        # landed, and not asked again)
        self.fixed = set(fixed_maps(g)[0].tolist())
        self.refs = [0] * len(g.nodes)     # how many edges (and the root) lead to each node
        self.refs[g.root] += 1
        for n in g.nodes:
            for c in n.children:
                self.refs[c] += 1
        # T-nodes already pushed into an operand stay there: pushed on through the unions
        # below, every map would go down to every primitive of an expanded system (the
        # tree at 10 written out: 192 303 nodes became 896 570)
        self.landed: set[int] = set()
        # T-nodes whose run stays where it is whenever it is asked (it ends on no union, or
        # passes a map that is not constant): a chain of 10,000 maps was walked from each
        # of its nodes in turn, 7.5 s
        self.stays: set[int] = set()

    def distribute(self) -> int:
        """Every constant run of T-nodes over a union pushed into the union's operands;
        returns the root (the union, where the root was such a run)."""
        nodes = self.g.nodes
        i = 0
        while i < len(nodes):           # nodes appended on the way are visited too
            for j, head in enumerate(nodes[i].children):
                nodes[i].children[j] = self.pushed(head)
            i += 1
        return self.pushed(self.g.root)

    def pushed(self, head: int) -> int:
        """What a parent points to instead of `head`: the union below head's run of
        constant T-nodes, which now carries the run in each operand; head itself where it
        is no such run."""
        nodes, refs = self.g.nodes, self.refs
        chain, x = [], head
        while (nodes[x].kind == TRANSFORM and refs[x] == 1 and x not in self.landed
               and x not in self.stays):
            chain.append(x)
            x = nodes[x].children[0]
        if x in self.stays:         # so does every run above it
            self.stays.update(chain)
            return head
        if not chain:
            return head
        if nodes[x].kind != UNION or refs[x] != 1:
            self.stays.update(chain)
            return head
        # the matrices last: most runs end elsewhere, and a run with a map that is not
        # constant is taken from below that map, when its own parent is visited
        for k in range(len(chain) - 1, -1, -1):
            if chain[k] not in self.fixed:
                self.stays.update(chain[:k + 1])
                return head
        for k, operand in enumerate(nodes[x].children):
            # the first operand takes the run itself, which nothing else refers to
            nodes[x].children[k] = self.push(chain if k == 0 else self.copy(chain), operand)
        return x

    def copy(self, chain: list[int]) -> list[int]:
        """New nodes for the run `chain`, linked in its order; the last one's child is set
        by push."""
        nodes, out = self.g.nodes, []
        for t in chain:
            nodes.append(_copy(nodes[t], [-1]))
            self.refs.append(1)
            out.append(len(nodes) - 1)
        for a, b in zip(out, out[1:]):
            nodes[a].children[0] = b
        return out

    def push(self, chain: list[int], operand: int) -> int:
        """The operand with the run of T-nodes `chain` (nodes of its own) below its
        C-nodes: a C-node only assigns parameters, which constant arguments do not read."""
        nodes = self.g.nodes
        parent, below = None, operand      # a loop: the C-nodes may be thousands deep
        while nodes[below].kind == CALC and self.refs[below] == 1:
            parent, below = below, nodes[below].children[0]
        nodes[chain[-1]].children[0] = below
        self.landed.update(chain)
        if parent is None:
            return chain[0]
        nodes[parent].children[0] = chain[0]
        return operand

    def splice(self):
        nodes, refs = self.g.nodes, self.refs
        for i, node in enumerate(nodes):
            if node.kind != UNION or refs[i] == 0:
                continue
            k = 0
            while k < len(node.children):
                c = node.children[k]
                inner = nodes[c]
                if (inner.kind == UNION and refs[c] == 1 and len(inner.children) <= SPLICE
                        and len(node.children) + len(inner.children) - 1 <= OPERANDS):
                    node.children[k:k + 1] = inner.children
                    node.edge_spans[k:k + 1] = inner.edge_spans
                    refs[c] = 0
                else:
                    k += 1
