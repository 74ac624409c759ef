"""playerstage.sweep's plans: parsing, expansion into runs, and every refusal of a bad plan
(each before any run, naming the plan line, the placeholder or the point)."""

import pickle
import textwrap

import pytest

from playerstage.sweep import Plan, PlanError, RunSpec, load_plan
from playerstage.sweep import worldtext

TEMPLATE = """\
# two robots in a walled arena; range and speed come from the plan
interval_sim 100
define bot position (
  size [0.4 0.4 0.4] drive "diff"
  ranger ( sensor ( range [0 {{range}}] fov 90 samples 5 ) )
)
model ( name "wall" pose [4 0 0 0] size [0.2 4 1] )
bot ( name "r0" pose [0 0 0 0] )
bot ( name "r1" pose [2 1 0 180] )
"""


def write(tmp_path, plan: str, template: str = TEMPLATE):
    (tmp_path / "arena.world.tmpl").write_text(template)
    path = tmp_path / "plan.toml"
    path.write_text(textwrap.dedent(plan))
    return path


def refused(tmp_path, plan: str, template: str = TEMPLATE, check=True) -> str:
    with pytest.raises(PlanError) as e:
        load_plan(write(tmp_path, plan, template)).runs(check=check)
    return str(e.value)


def test_grid_times_seeds_in_order_with_filled_worlds(tmp_path):
    plan = load_plan(write(tmp_path, """\
        world = "arena.world.tmpl"
        duration = 2
        seeds = 3
        [params]
        range = [1.0, 2.5]
        "r0.pose" = [[0, 0, 0, 0], [1, -1, 0, 90]]
    """))
    runs = plan.runs()
    assert len(runs) == 2 * 2 * 3
    assert [(r.params["range"], r.params["r0.pose"][0], r.seed) for r in runs[:4]] == [
        (1.0, 0, 1), (1.0, 0, 2), (1.0, 0, 3), (1.0, 1, 1)]
    assert len({r.run_id for r in runs}) == 12
    r = runs[4]
    assert r.world_name == "arena.world" and r.world_dir == str(tmp_path)
    assert "range [0 1.0]" in r.world_text and "{{" not in r.world_text
    # the override lands inside r0's entity, on its closing line, after the pose it replaces
    line = [l for l in r.world_text.splitlines() if 'name "r0"' in l][0]
    assert line.endswith('pose [ 1 -1 0 90 ] )'), line
    assert r.world_text.count("\n") == TEMPLATE.count("\n")
    assert r.duration == 2.0 and r.steps is None
    # ids are stable (same plan, same ids) and file-name safe; a spec pickles
    again = load_plan(tmp_path / "plan.toml").runs(check=False)
    assert [x.run_id for x in again] == [x.run_id for x in runs]
    assert all(set(x.run_id) <= set("abcdefghijklmnopqrstuvwxyz0123456789._-+")
               for x in runs)
    assert pickle.loads(pickle.dumps(r)) == r
    assert isinstance(r, RunSpec)


def test_explicit_points_seed_list_and_python_plan(tmp_path):
    (tmp_path / "arena.world.tmpl").write_text(TEMPLATE)
    plan = Plan(world="arena.world.tmpl", steps=5, seeds=[7, 9],
                points=[{"range": 1.0}, {"range": 3.0, "r1.pose": [3, 0, 0, 0]}],
                base_dir=str(tmp_path))
    runs = plan.runs()
    assert [(r.params, r.seed) for r in runs] == [
        ({"range": 1.0}, 7), ({"range": 1.0}, 9),
        ({"range": 3.0, "r1.pose": [3, 0, 0, 0]}, 7), ({"range": 3.0, "r1.pose": [3, 0, 0, 0]}, 9)]
    assert runs[0].steps == 5


def test_unknown_key_names_its_line(tmp_path):
    msg = refused(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5

        sedes = 3
    """)
    assert "plan.toml:4: sedes: unknown key" in msg


def test_unknown_metrics_key_names_its_line(tmp_path):
    msg = refused(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
        [params]
        range = [1.0]
        [metrics]
        evrey = 3
    """)
    assert "plan.toml:6: [metrics] evrey: unknown key" in msg


def test_unknown_parameter_names_its_line(tmp_path):
    msg = refused(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
        [params]
        range = [1.0]
        rnage = [2.0]
    """)
    assert "plan.toml:5: [params] rnage: unknown parameter" in msg and "{{rnage}}" in msg


def test_python_params_are_allowed(tmp_path):
    runs = load_plan(write(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
        python_params = ["gain"]
        [params]
        range = [1.0]
        gain = [0.1, 0.2]
    """)).runs()
    assert [r.params["gain"] for r in runs] == [0.1, 0.2]


def test_placeholder_left_unset_names_it_and_its_template_line(tmp_path):
    msg = refused(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
    """)
    assert "arena.world.tmpl:5: placeholder {{range}} is left unset" in msg


def test_placeholder_unset_in_one_point_names_the_point(tmp_path):
    msg = refused(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
        [[points]]
        range = 2.0
        [[points]]
        "r0.pose" = [1, 1, 0, 0]
    """)
    assert "placeholder {{range}} is left unset: point {r0.pose=[1, 1, 0, 0]}" in msg


def test_malformed_placeholder_is_refused(tmp_path):
    msg = refused(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
    """, template=TEMPLATE.replace("interval_sim 100", "interval_sim {{ 100 }}"))
    assert "arena.world.tmpl:2:" in msg and "not part of a {{name}} placeholder" in msg


def test_placeholders_in_comments_are_left_alone():
    text = '# {{range}} and {{ junk\nsize [{{a}} 1] name "{{b}}#{{c}}" # {{d}}\n'
    assert worldtext.placeholders(text) == {"a": 2, "b": 2, "c": 2}
    assert worldtext.fill(text, {"a": 0.5, "b": "x", "c": 3}) == (
        '# {{range}} and {{ junk\nsize [0.5 1] name "x#3" # {{d}}\n')


def test_worldfile_error_in_one_point_names_the_point(tmp_path):
    # a negative range is fine for the template but not for the worldfile reader
    msg = refused(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
        [params]
        range = [2.0, "oops"]
    """)
    assert "point {range='oops'} seed 1: the worldfile does not load" in msg
    assert "arena.world:5" in msg


def test_override_of_a_model_that_is_not_there(tmp_path):
    msg = refused(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
        [params]
        range = [2.0]
        "r9.pose" = [[0, 0, 0, 0]]
    """)
    assert 'no model with `name "r9"`' in msg and "point {range=2.0" in msg


def test_length_seeds_and_callables_are_checked(tmp_path):
    base = 'world = "arena.world.tmpl"\n[params]\nrange = [1.0]\n'
    assert "exactly one of `duration`" in refused(tmp_path, base)
    assert "plan.toml:1: steps" in refused(tmp_path, "steps = 0\n" + base)
    assert "plan.toml:2: seeds" in refused(tmp_path, "steps = 1\nseeds = 0\n" + base)
    msg = refused(tmp_path, 'steps = 1\ncontroller = "no_such_module_xyz:drive"\n' + base)
    assert "plan.toml:2: controller" in msg and "cannot load it" in msg
    msg = refused(tmp_path, "steps = 1\n" + base + '[metrics]\ncustom = ["m.py:f"]\n')
    assert "[metrics] custom" in msg and "no file" in msg


def test_builtin_controller_must_attach(tmp_path):
    # `wander` attaches to r0 (it has a ranger); an unknown controller is refused, with the line
    ok = load_plan(write(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
        [params]
        range = [2.0]
        [controllers]
        "r*" = "wander"
    """)).runs()
    assert ok[0].world_text.count('ctrl "wander"') == 2
    msg = refused(tmp_path, """\
        world = "arena.world.tmpl"
        steps = 5
        [params]
        range = [2.0]
        [controllers]
        r0 = "wandr"
    """)
    assert "plan.toml:6: [controllers] r0" in msg and "not built in" in msg


def test_named_entities_skip_defines_comments_and_strings():
    text = ('define r0 position ( name "r0" )\n# bot ( name "c" )\n'
            'bot ( name "a" ranger ( name "a.r" ) )\nbot( color "name" name "b")\n')
    assert [e.name for e in worldtext.named_entities(text)] == ["a.r", "a", "b"]
    out = worldtext.set_properties(text, [("a", "pose", [1, 2, 0, 0]), ("b", "color", "red")])
    assert 'bot ( name "a" ranger ( name "a.r" )  pose [ 1 2 0 0 ] )' in out
    assert 'name "b" color "red" )' in out


def test_includes_resolve_next_to_the_template(tmp_path):
    (tmp_path / "inc").mkdir()
    (tmp_path / "inc" / "bot.inc").write_text(
        'define bot position ( size [0.4 0.4 0.4] drive "diff" )\n')
    (tmp_path / "w.world.tmpl").write_text(
        'include "inc/bot.inc"\ninterval_sim {{dt}}\nbot ( name "r0" )\n')
    plan = Plan(world="w.world.tmpl", steps=3, params={"dt": [50, 100]}, base_dir=str(tmp_path))
    from playerstage.sweep import execute

    results = [execute(s) for s in plan.runs()]
    assert [r["error"] for r in results] == [None, None]
    assert [r["sim_time"] for r in results] == [0.15, 0.3]
    (tmp_path / "inc" / "bot.inc").unlink()
    with pytest.raises(PlanError, match=r"point \{dt=50\} seed 1: the worldfile does not load"):
        plan.runs()


def test_run_ids_keep_signs_and_are_never_hidden():
    from playerstage.sweep.plan import run_id

    a, b = run_id({"x": -1}, 1), run_id({"x": 1}, 1)
    assert a.startswith("x--1_s1_") and b.startswith("x-1_s1_")
    assert run_id({".m.pose": [1]}, 2).startswith("p.m.pose-1_s2_")
    assert run_id({}, 4).startswith("s4_") and run_id({}, 4) == run_id({}, 4)
    assert "/" not in run_id({"n": "a/b c"}, 1)


def test_paths_in_run_specs_are_absolute(tmp_path, monkeypatch):
    # a worker may run elsewhere (another cwd, another machine with the same paths)
    import os

    (tmp_path / "arena.world.tmpl").write_text(TEMPLATE)
    monkeypatch.chdir(tmp_path)
    r = Plan(world="arena.world.tmpl", steps=1, params={"range": 1.0},
             python_path=["lib"]).runs()[0]
    assert r.world_dir == str(tmp_path)
    assert list(r.python_path) == [str(tmp_path), str(tmp_path / "lib")]
    assert os.path.isabs(r.world_dir)


def test_seed_placeholder_and_derived_text(tmp_path):
    (tmp_path / "w.world.tmpl").write_text(
        'define bot position ( size [0.4 0.4 0.4] )\nbot ( name "s{{seed}}" )\n{{more}}\n')
    (tmp_path / "gen.py").write_text(
        "def bots(params, seed):\n"
        "    if params['n'] < 0:\n"
        "        raise ValueError('n must be >= 0')\n"
        "    return '\\n'.join(f'bot ( name \"b{i}\" pose [{i} 2 0 0] )' for i in range(params['n']))\n")
    plan = Plan(world="w.world.tmpl", steps=1, seeds=[7], params={"n": [0, 2]},
                derive={"more": "gen.py:bots"}, python_params=["n"], base_dir=str(tmp_path))
    runs = plan.runs()
    assert 'name "s7"' in runs[0].world_text and "b0" not in runs[0].world_text
    assert 'bot ( name "b1" pose [1 2 0 0] )' in runs[1].world_text
    plan.params = {"n": [1, -1]}
    with pytest.raises(PlanError, match=r"plan: \[derive\] more: point \{n=-1\} seed 7: "
                                        r"ValueError: n must be >= 0"):
        plan.runs()
