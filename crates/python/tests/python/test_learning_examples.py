"""examples/python's learning loops: the cross-entropy goal-reaching trainer improves its mean
return by the margin its docstring states, and the PettingZoo multi-robot example runs its
robots to their goals."""

import re

from conftest import EXAMPLES, run_script

#: The rise of the mean return train_goal_cem.py's docstring promises (first to last iteration).
MARGIN = 1.5


def test_cem_training_raises_the_mean_return():
    # CI's budget: 6 iterations of 16 candidates x 4 episodes (384 episodes, about 1 s)
    out = run_script(EXAMPLES / "train_goal_cem.py", "--iterations", 6, "--population", 16,
                     "--episodes", 4, "--steps", 60, "--seed", 1)
    means = [float(m) for m in re.findall(r"iteration \d+: mean return (-?[\d.]+)", out)]
    assert len(means) == 6, out
    first, last = means[0], means[-1]
    assert last - first > MARGIN, out
    assert f"first {first:.3f}, last {last:.3f}" in out


def test_cem_training_is_deterministic():
    args = ("--iterations", 2, "--population", 4, "--elite", 2, "--episodes", 1, "--steps", 20)
    a = run_script(EXAMPLES / "train_goal_cem.py", *args)
    b = run_script(EXAMPLES / "train_goal_cem.py", *args)
    strip = lambda s: re.sub(r" in [\d.]+ s\)", ")", s)  # noqa: E731 (the timing differs)
    assert strip(a) == strip(b)


def test_pettingzoo_example():
    out = run_script(EXAMPLES / "multi_robot_pettingzoo.py", "--seed", 3)
    for robot in ("r0", "r1", "r2", "r3"):
        assert re.search(rf"^{robot}: reached its goal after \d+ steps, return [\d.]+$", out,
                         re.M), out
    assert "4 of 4 robots reached their goals" in out
