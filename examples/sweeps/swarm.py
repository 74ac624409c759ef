"""Helpers of the swarm sweep (swarm.toml): the robots' model lines and a swarm metric."""

import math

SPACING = 0.8  # metres between neighbouring start positions
SLOTS = 9  # start positions per row: a 9 x 9 grid centred in the arena


def robots(params, seed):
    """``{{swarm}}``: ``params["robots"]`` swarmbot lines on a grid of start positions
    (skipping the pillars' cells), headings spread over the circle. The same for every seed:
    seeds change what the robots do (wander's random turns), not where they start."""
    count = params["robots"]
    lines = []
    half = (SLOTS - 1) / 2 * SPACING
    for slot in range(SLOTS * SLOTS):
        if len(lines) == count:
            break
        x = -half + (slot % SLOTS) * SPACING
        y = half - (slot // SLOTS) * SPACING
        if any(abs(x - px) < 0.7 and abs(y - py) < 0.7 for px, py in ((-1.5, 1.5), (1.5, -1.5))):
            continue
        heading = (len(lines) * 137.5) % 360  # golden-angle spread
        lines.append(f'swarmbot ( name "r{len(lines)}" pose [ {x:.2f} {y:.2f} 0 {heading:.1f} ] )')
    if len(lines) < count:
        raise ValueError(f"{count} robots do not fit the arena's {len(lines)} start positions")
    return "\n".join(lines)


def spread(world):
    """Custom metric: how far the robots are, on average, from their centroid (m), and the
    share of them that are stalled right now."""
    names = [n for n in world.models("position")]
    poses = [world.global_pose(n) for n in names]
    cx = sum(p.x for p in poses) / len(poses)
    cy = sum(p.y for p in poses) / len(poses)
    dispersion = sum(math.hypot(p.x - cx, p.y - cy) for p in poses) / len(poses)
    stalled = sum(bool(world.odometry(n).stall) for n in names) / len(names)
    return {"dispersion": dispersion, "stalled_share": stalled}
