"""Transfer planning: moving loops between needles with xfer and rack (thesis ch. 6.8.3-4).

`move(bed, moves)` takes (stitch, from, to) triples for loops that must change needle and
emits the transfers. Cross-bed moves go directly at the racking that aligns them; same-bed
shifts are parked on the opposite bed's sliders and put back at most `max_rack` needles
closer per round, so no loop lands on a needle another loop has not left yet.
"""

from __future__ import annotations

from collections import defaultdict

from knitc.passes.bed import SLIDERS, Bed, Pos, Unsupported

Move = tuple[int, Pos, Pos]


def move(bed: Bed, moves: list[Move]) -> None:
    if not moves:
        return
    shift = [m for m in moves if m[1][0] == m[2][0] and m[1] != m[2]]
    cross = []
    for s, src, dst in moves:
        if src[0] != dst[0]:
            # at racking r, back k faces front k + r
            r = src[1] - dst[1] if src[0] == "f" else dst[1] - src[1]
            cross.append((r, s, src, dst))
    _cross(bed, cross)
    _shift(bed, shift)


def _cross(bed: Bed, cross: list) -> None:
    for r, s, src, dst in sorted(cross, key=lambda m: (m[0], m[2])):
        bed.set_rack(r)
        if bed.where.get(s) == src:
            bed.xfer(src, dst, s)
    bed.set_rack(0)


def _shift(bed: Bed, shift: list[Move]) -> None:
    if not shift:
        return
    # Same-bed shifts, in rounds: every loop still away from its target is parked on the
    # facing slider and put back at most `max_rack` needles closer. The loops of a course
    # transition keep their order (wales never cross), so a loop never lands on a needle
    # another loop still holds, except its decrease partner.
    todo = {s: dst for s, src, dst in shift}
    final = set(todo.values())
    rounds = 0
    while True:
        rounds += 1
        if rounds > 4 + max((abs(d[1] - p[1]) for _s, p, d in shift), default=0):
            raise Unsupported("shaping moves do not converge")
        pending = [(s, bed.where[s], dst) for s, dst in todo.items()
                   if s in bed.where and bed.where[s] != dst]
        if not pending:
            break
        parked = []
        seen: set[Pos] = set()
        for s, src, dst in sorted(pending, key=lambda m: m[1]):
            if src in seen:  # stacked loops travel together
                continue
            seen.add(src)
            slider = (SLIDERS[1] if src[0] == "f" else SLIDERS[0], src[1])
            bed.xfer(src, slider, s)
            step = max(-bed.max_rack, min(bed.max_rack, dst[1] - src[1]))
            parked.append((s, slider, (src[0], src[1] + step)))
        by_rack: dict[int, list] = defaultdict(list)
        for s, slider, land in parked:
            # back slider i faces front i + r; front slider i faces back i - r
            r = land[1] - slider[1] if land[0] == "f" else slider[1] - land[1]
            by_rack[r].append((s, slider, land))
        for r in sorted(by_rack, key=lambda x: (abs(x), x)):
            bed.set_rack(r)
            for s, slider, land in sorted(by_rack[r], key=lambda m: m[1]):
                if bed.loops.get(land, 0) and land not in final:
                    raise Unsupported(f"a shaping move would land on {land[0]}{land[1]}, "
                                      "which holds another loop")
                bed.xfer(slider, land, s)
        bed.set_rack(0)
