"""Generated scenes written as one wide union, and the same scenes nested by hand into a
balanced hierarchy of unions of four, and a block with 1,000 holes as `cube \\ (∪ of
holes)` and as `cube \\ hole \\ hole ...`, for timing the trees over wide unions and
differences (graph/operand_trees.py) with tools/ab.py:

    python tools/wide_scenes.py /tmp/wide
    python tools/ab.py /tmp/before . --rounds 5 /tmp/wide/spheres_flat_10000.pcsg \
        /tmp/wide/spheres_nested_10000.pcsg /tmp/wide/forest_flat_500.pcsg \
        /tmp/wide/forest_nested_500.pcsg --options "--size 320x240"

The flat and nested files of a scene draw the same spheres (their pictures are the same
where no two operands' surfaces coincide); the forests' trees differ between the two,
since rand() hashes each tree's operand number and the nest numbers them otherwise.
"""
from __future__ import annotations

import random
import sys
from pathlib import Path


def spheres(n: int) -> tuple[list, str]:
    rng = random.Random(1)
    r = 5 * n ** (-1 / 3)
    items = []
    for _ in range(n):
        x, y, z = (rng.random() * 10 for _ in range(3))
        items.append(((x, y, z), f"move({x:.4f}, {y:.4f}, {z:.4f}) uscale({r:.4f}) sphere"))
    return items, "#camera eye=(25, -20, 18) at=(5, 5, 5) fov=40\n"


def forest(n: int) -> tuple[list, str]:
    rng = random.Random(2)
    items = []
    for _ in range(n):
        x, y = rng.random() * 50, rng.random() * 50
        items.append(((x, y, 0.0), f"move({x:.3f}, {y:.3f}, 0) {{d = 4}} T"))
    rules = ("T if(d > 0, 2, 1)\n1: T → scale(0.05, 0.05, 1) cylinder\n"
             "2: T → scale(0.05, 0.05, 1) cylinder ∪ move(0, 0, 1) {d = d - 1} "
             "(rotz(rand() * 360) roty(30) uscale(0.7) T ∪ "
             "rotz(rand() * 360) roty(-30) uscale(0.7) T)\n")
    return items, "#camera eye=(60, -80, 50) at=(25, 25, 0) fov=40\n" + rules


def holes(n: int) -> list[str]:
    rng = random.Random(3)
    return [f"move({rng.uniform(-1, 1):.4f}, {rng.uniform(-1, 1):.4f}, "
            f"{rng.uniform(-1, 1):.4f}) uscale({rng.uniform(0.05, 0.15):.3f}) sphere"
            for _ in range(n)]


def nested(items: list, axis: int = 0) -> str:
    """A balanced nest of unions by median splits along the axes in turn."""
    if len(items) <= 4:
        return "(" + " ∪ ".join(text for _, text in items) + ")"
    items = sorted(items, key=lambda it: it[0][axis])
    half = len(items) // 2
    return (f"({nested(items[:half], (axis + 1) % 3)} ∪\n"
            f"{nested(items[half:], (axis + 1) % 3)})")


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for name, make, sizes in (("spheres", spheres, (1000, 10000)), ("forest", forest, (500,))):
        for n in sizes:
            items, tail = make(n)
            (out / f"{name}_flat_{n}.pcsg").write_text(
                " ∪\n".join(text for _, text in items) + "\n" + tail)
            (out / f"{name}_nested_{n}.pcsg").write_text(nested(items) + "\n" + tail)
    camera = "#camera eye=(3, -4, 2.5) at=(0, 0, 0) fov=40\n"
    drilled = holes(1000)
    (out / "cheese_1000.pcsg").write_text("cube \\ (" + " ∪\n".join(drilled) + ")\n" + camera)
    (out / "cheesechain_1000.pcsg").write_text("cube \\ " + " \\\n".join(drilled) + "\n"
                                               + camera)
    print(f"wrote the scenes into {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "wide_scenes"))
