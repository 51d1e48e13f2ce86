"""hevo.Task: shipped scenarios, scenario files, overrides, and their errors."""

import pytest

import hevo


def test_shipped_and_file_tasks(repo):
    assert "solve_maze" in hevo.shipped_tasks()
    maze = hevo.Task("solve_maze")
    assert maze.name == "solve_maze"
    assert maze.n_variants == len(maze.variant_names) == 4
    t_maze = hevo.Task(repo / "scenarios" / "examples" / "t_maze.toml")
    assert t_maze.n_variants == len(t_maze.variant_names) >= 2


def test_overrides_change_the_settings():
    task = hevo.Task("follow_wall", max_cycles=77, end_on_collision=False, robot={"v_max": 0.08})
    assert task.max_cycles == 77
    settings = task.settings()
    assert settings["end_on_collision"] is False
    assert settings["robot"]["v_max"] == pytest.approx(0.08)
    assert hevo.Task("follow_wall").settings()["end_on_collision"] is True


def test_bad_settings_name_the_key():
    with pytest.raises(hevo.ConfigError, match="robot") as raised:
        hevo.Task("follow_wall", robot={"vmax": 0.1})
    assert "vmax" in str(raised.value)
    with pytest.raises(hevo.ConfigError, match="robot.v_max"):
        hevo.Task("follow_wall", robot={"v_max": -1.0})
    with pytest.raises(hevo.ConfigError):
        hevo.Task("follow_wall", max_cycles="long")


def test_unknown_tasks_carry_the_command_lines_messages(tmp_path, hevo_cli, repo):
    for name in ("no_such_task", str(tmp_path / "missing.toml")):
        with pytest.raises(hevo.ConfigError) as raised:
            hevo.Task(name)
        cli = hevo_cli(
            "eval", repo / "controllers" / "follow_wall.json", "--task", name, check=False
        )
        assert cli.returncode != 0
        assert cli.stderr.strip() == f"error: {raised.value}"
    broken = tmp_path / "broken.toml"
    broken.write_text("[scenario]\nname = 3\n")
    with pytest.raises(hevo.ConfigError) as raised:
        hevo.Task(str(broken))
    cli = hevo_cli("eval", repo / "controllers" / "follow_wall.json", "--task", broken, check=False)
    assert cli.stderr.strip() == f"error: {raised.value}"
