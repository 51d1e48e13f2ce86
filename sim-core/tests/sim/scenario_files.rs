//! Scenario files as a researcher writes them: the example scenarios compile and behave as their
//! files say, and every kind of mistake is refused with the file, the key path and, where the
//! parser knows it, the line.

use hevo_sim_core::{Ending, Evaluator, Sample, TaskConfig};
use hevo_sim_core::{SHIPPED, Scenario};
use std::sync::Arc;

use crate::support::{
    EXAMPLES, FIND_WANDERER, Fixed, ROOM_TO_CORRIDOR, T_MAZE, example, example_task,
};

fn t_maze() -> TaskConfig {
    example_task("t_maze")
}

/// The error `text` gets, as printed.
fn refusal(text: &str) -> String {
    Scenario::parse(text, "mine.toml")
        .expect_err("the scenario should be refused")
        .to_string()
}

/// The error `base` gets with `from` replaced by `to`; the error names the file.
fn edit_refusal(base: &str, from: &str, to: &str) -> String {
    assert!(base.contains(from), "{from}");
    let error = refusal(&base.replace(from, to));
    assert!(error.starts_with("mine.toml"), "{to}: {error}");
    error
}

#[test]
fn the_example_t_maze_compiles_with_two_variants_and_the_f2_range() {
    let task = t_maze();
    assert_eq!(task.validate(), Ok(()));
    assert_eq!(task.name(), "t_maze");
    assert_eq!(task.scenario.n_variants(), 2);
    assert_eq!(task.fitness_range(), (0.0, 2.0));
    assert_eq!(task.max_cycles(), 500);
    // Not a paper task: it travels as its own text, which a worker can compile without files.
    let json = serde_json::to_string(&task).unwrap();
    let back: TaskConfig = serde_json::from_str(&json).unwrap();
    assert_eq!(back, task);
}

#[test]
fn driving_straight_into_the_junction_wall_is_a_collision_in_both_variants() {
    // The stem ends in the junction's far wall: a robot that never turns hits it, whatever
    // light flashed, and scores a third of its progress.
    let evaluator = Evaluator::new(t_maze()).unwrap();
    for variant in 0..2 {
        let outcome = evaluator.evaluate(
            &mut Fixed::straight(),
            Sample {
                seed: 3,
                variant: Some(variant),
            },
        );
        assert_eq!(outcome.ending, Ending::Collision, "variant {variant}");
        assert_eq!(outcome.variant, variant);
        assert!(
            outcome.fitness > 0.0 && outcome.fitness < 1.0 / 3.0,
            "variant {variant}: {}",
            outcome.fitness
        );
    }
}

/// The example T-maze with only the listed sensors.
fn t_maze_sensing(sensors: &str) -> TaskConfig {
    let text = T_MAZE.replacen(
        "max_cycles = 500",
        &format!("sensors = {sensors}\nmax_cycles = 500"),
        1,
    );
    TaskConfig::from_scenario(Arc::new(Scenario::parse(&text, "mine.toml").unwrap()))
}

#[test]
fn a_sensor_the_robot_lacks_reads_zero_and_the_rest_still_sense() {
    let variant_0 = Sample {
        seed: 3,
        variant: Some(0),
    };
    let trace = |task: TaskConfig| {
        Evaluator::new(task)
            .unwrap()
            .evaluate_traced(&mut Fixed::straight(), variant_0)
    };
    // Driving straight up the stem, the robot passes the flashing light and meets the wall.
    let all = trace(t_maze());
    let max_of = |trace: &hevo_sim_core::Trace, input: fn(&hevo_sim_core::SensorFrame) -> f32| {
        trace
            .cycles
            .iter()
            .map(|cycle| input(&cycle.frame))
            .fold(0.0, f32::max)
    };
    use hevo_sim_core::{InputGroup, SensorFrame};
    let ir = |frame: &SensorFrame| {
        let values = frame.values(InputGroup::IR);
        values.iter().copied().fold(0.0, f32::max)
    };
    let light = |frame: &SensorFrame| {
        let values = frame.values(InputGroup::LIGHT);
        values.iter().copied().fold(0.0, f32::max)
    };
    assert!(max_of(&all, ir) > 0.5 && max_of(&all, light) > 0.5);

    let blind = trace(t_maze_sensing(r#"["light"]"#));
    assert_eq!(max_of(&blind, ir), 0.0);
    assert!(max_of(&blind, light) > 0.5, "the light is still seen");
    let dark = trace(t_maze_sensing(r#"["ir"]"#));
    assert_eq!(max_of(&dark, light), 0.0);
    assert!(max_of(&dark, ir) > 0.5, "the wall is still seen");
    // The world does not depend on what the robot senses: the lights flash all the same.
    for (dark_cycle, blind_cycle) in dark.cycles.iter().zip(&blind.cycles) {
        assert_eq!(dark_cycle.lit_lights, blind_cycle.lit_lights);
    }
    // Listing every sensor is the default, bit for bit.
    let listed = trace(t_maze_sensing(r#"["near_robot", "light", "ir"]"#));
    assert_eq!(listed.cycles, all.cycles);
    assert_eq!(listed.outcome, all.outcome);
}

#[test]
fn a_controller_reading_a_sensor_the_robot_lacks_is_refused() {
    use hevo_sim_core::BatchEvaluator;
    use hevo_sim_core::InputGroup;
    use hevo_sim_core::{ControllerFile, NodeSpec};
    let leaf = |name: &str, inputs: Vec<InputGroup>| {
        let spec = NodeSpec::primitive(name, inputs, 2);
        let genes = vec![0.5; spec.topology().n_genes()];
        spec.with_genome(genes)
    };
    let reads_light = ControllerFile::new(NodeSpec::arbitrator(
        "top",
        vec![InputGroup::IR],
        2,
        vec![
            leaf("ir_leaf", vec![InputGroup::IR]),
            leaf("light_leaf", vec![InputGroup::LIGHT]),
        ],
    ));
    let error = BatchEvaluator::new(reads_light.clone(), t_maze_sensing(r#"["ir"]"#))
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("'top'") && error.contains("reads 'light'") && error.contains("it has ir"),
        "{error}"
    );
    BatchEvaluator::new(reads_light, t_maze()).expect("the e-puck has every sensor");
}

#[test]
fn every_example_compiles_with_one_goal_per_variant() {
    for (name, text) in EXAMPLES {
        let scenario = Scenario::parse(text, &format!("{name}.toml"))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(scenario.name(), name);
        assert_eq!(scenario.legacy(), None, "{name}");
        let goals: std::collections::BTreeSet<_> =
            scenario.variants.iter().map(|v| v.goal.clone()).collect();
        assert_eq!(
            goals.len(),
            scenario.variants.len(),
            "{name}: goals {goals:?}"
        );
        let task = TaskConfig::from_scenario(Arc::new(scenario));
        assert_eq!(task.validate(), Ok(()), "{name}");
    }
}

#[test]
fn the_triple_t_maze_has_eight_variants_and_its_stem_ends_in_a_wall() {
    let (_, text) = EXAMPLES[1];
    let task = TaskConfig::from_scenario(Arc::new(Scenario::parse(text, "t.toml").unwrap()));
    assert_eq!(task.scenario.n_variants(), 8);
    assert_eq!(task.max_cycles(), 1500);
    // Three lights flash in every variant, one of each row.
    for variant in &task.scenario.variants {
        assert_eq!(variant.flashes.iter().filter(|&&on| on).count(), 3);
    }
    // A robot that never turns drives up the stem into the bar's far wall, in every variant.
    let evaluator = Evaluator::new(task).unwrap();
    for variant in 0..8 {
        let outcome = evaluator.evaluate(
            &mut Fixed::straight(),
            Sample {
                seed: 1,
                variant: Some(variant),
            },
        );
        assert_eq!(outcome.ending, Ending::Collision, "variant {variant}");
        assert!(outcome.fitness > 0.0 && outcome.fitness < 1.0 / 3.0);
    }
}

#[test]
fn an_unknown_key_names_the_key_path_and_the_line() {
    let text = T_MAZE.replace("goal = \"left_end\"", "goal = \"left_end\"\ngaol = 1");
    let error = refusal(&text);
    assert!(error.starts_with("mine.toml:"), "{error}");
    assert!(error.contains("unknown field `gaol`"), "{error}");
    let line = T_MAZE
        .lines()
        .position(|l| l == "goal = \"left_end\"")
        .unwrap()
        + 2;
    assert!(error.contains(&format!(":{line}:")), "line {line}: {error}");
}

#[test]
fn a_refusal_after_parsing_names_the_line_too() {
    let error = edit_refusal(T_MAZE, "solved = \"in goal\"", "solved = \"in kitchen\"");
    let line = T_MAZE
        .lines()
        .position(|l| l == "solved = \"in goal\"")
        .unwrap()
        + 1;
    assert!(
        error.starts_with(&format!("mine.toml:{line}:")),
        "line {line}: {error}"
    );
    assert!(error.contains("at `end.solved`"), "{error}");
}

#[test]
fn references_to_missing_things_are_named() {
    for (from, to, expected) in [
        (
            "flash = [\"left\"]",
            "flash = [\"lefty\"]",
            "no light is named 'lefty'",
        ),
        ("goal = \"left_end\"", "goal = \"nowhere\"", "nowhere"),
        (
            "timeout = \"0\"",
            "timeout = \"progress / 0\"",
            "division by zero",
        ),
        (
            "timeout = \"0\"",
            "timeout = \"speed\"",
            "expected a number, time_bonus, progress",
        ),
        (
            "schema = \"hevo.scenario/1\"",
            "schema = \"hevo.scenario/9\"",
            "is not hevo.scenario/1",
        ),
        ("max_cycles = 500", "max_cycles = 0", "max_cycles"),
        (
            "max_cycles = 500",
            "sensors = [\"ir\", \"sonar\"]\nmax_cycles = 500",
            "sensors[1]",
        ),
        (
            "max_cycles = 500",
            "sensors = [\"ir\", \"ir\"]\nmax_cycles = 500",
            "'ir' is listed twice",
        ),
        (
            "max_cycles = 500",
            "sensors = []\nmax_cycles = 500",
            "name at least one of ir, light, near_robot",
        ),
    ] {
        let error = edit_refusal(T_MAZE, from, to);
        assert!(error.contains(expected), "{to}: {error}");
    }
}

#[test]
fn a_controller_lacking_a_child_a_phase_asks_for_is_refused() {
    use hevo_sim_core::InputGroup;
    use hevo_sim_core::{BatchEvaluator, controller_fits};
    use hevo_sim_core::{ControllerFile, NodeKind, NodeSpec};
    let rescue = TaskConfig::shipped("rescue").unwrap();
    let leaf = |name: &str| {
        let spec = NodeSpec::primitive(name, vec![InputGroup::IR], 2);
        let genes = vec![0.5; spec.topology().n_genes()];
        spec.with_genome(genes)
    };
    let top = |children: [&str; 3]| {
        ControllerFile::new(NodeSpec::arbitrator(
            "rescue",
            vec![InputGroup::IR],
            2,
            children.map(leaf).to_vec(),
        ))
    };
    BatchEvaluator::new(
        top(["exit_room", "solve_maze", "return_room"]),
        rescue.clone(),
    )
    .expect("the children the phases ask for");
    let error = BatchEvaluator::new(top(["exit_room", "maze", "return_room"]), rescue.clone())
        .expect_err("refused")
        .to_string();
    let line = SHIPPED
        .iter()
        .find(|(name, _)| *name == "rescue")
        .map(|(_, text)| {
            text.lines()
                .position(|l| l == "child = \"solve_maze\"")
                .unwrap()
                + 1
        })
        .unwrap();
    assert_eq!(
        error,
        format!(
            "controller 'rescue' lacks a child its scenario's derived fitness asks for: \
             scenarios/rescue.toml:{line}: at `phase[1].child`: phase 'solve maze' asks for the \
             child 'solve_maze', the arbitrator's children are exit_room, maze, return_room"
        )
    );
    // A primitive makes no choices: nothing for the phases to count, nothing to refuse.
    let single = ControllerFile::new(leaf("single"));
    assert_eq!(single.root.kind, NodeKind::Primitive);
    assert_eq!(controller_fits(&single, &rescue.scenario), Ok(()));
}

#[test]
fn empty_regions_and_lights_that_never_flash_are_refused_with_their_lines() {
    let empty_rect = edit_refusal(
        T_MAZE,
        "[place]",
        "[regions]\nbay = { rect = [0.5, 0.0, 0.5, 1.0] }\n\n[place]",
    );
    let line = T_MAZE.lines().position(|l| l == "[place]").unwrap() + 2;
    assert_eq!(
        empty_rect,
        format!(
            "mine.toml:{line}: at `regions.bay.rect`: must be [x0, y0, x1, y1] with x0 < x1 \
             and y0 < y1: an empty region"
        )
    );
    // The second variant flashes the left light too: the right one is never seen.
    let never = T_MAZE.replacen("flash = [\"right\"]", "flash = [\"left\"]", 1);
    let error = refusal(&never);
    assert!(
        error.starts_with("mine.toml:")
            && error.ends_with("at `light[1]`: 'right' flashes in no variant"),
        "{error}"
    );
}

/// The example T-maze with its start moved 0.2 m back from the stem's first cell, into the wall
/// below it.
fn t_maze_starting_in_the_wall() -> String {
    T_MAZE.replacen("[place]\n", "[place]\nahead_m = -0.2\n", 1)
}

#[test]
fn a_start_touching_a_solid_is_refused_before_any_evaluation() {
    use hevo_sim_core::BatchEvaluator;
    use hevo_sim_core::InputGroup;
    use hevo_sim_core::{ControllerFile, NodeSpec};
    let text = t_maze_starting_in_the_wall();
    // It compiles: only building its worlds shows the start in the wall.
    let scenario = Arc::new(Scenario::parse(&text, "mine.toml").expect("it compiles"));
    let task = TaskConfig::from_scenario(scenario);
    let error = Evaluator::new(task.clone())
        .expect_err("refused")
        .to_string();
    let line = text.lines().position(|l| l == "[place]").unwrap() + 1;
    assert!(
        error.starts_with(&format!(
            "mine.toml:{line}: at `place`: the robot starts touching a solid: at (0."
        )),
        "{error}"
    );
    assert!(error.contains("in variant 0, seed 0"), "{error}");
    // Every evaluation path makes an evaluator first, the batch evaluator included.
    let spec = NodeSpec::primitive("still", vec![InputGroup::IR], 2);
    let genes = vec![0.0; spec.topology().n_genes()];
    let controller = ControllerFile::new(spec.with_genome(genes));
    let batch_error = BatchEvaluator::new(controller, task.clone())
        .expect_err("refused")
        .to_string();
    assert!(
        batch_error.contains("at `place`: the robot starts touching a solid"),
        "{batch_error}"
    );
    // The refused world can still be drawn, to see what is wrong.
    let env = Evaluator::for_drawing(task)
        .expect("a world to draw")
        .environment(Sample::seeded(0));
    assert!(env.scene.disc_hits(env.start.position(), 0.0375));
    // The example as shipped starts clear of every wall in the checked worlds and far more.
    Evaluator::new(t_maze())
        .expect("the example is valid")
        .check_starts(200)
        .expect("clear starts");
}

/// The example T-maze with a forbidden region `pit`, the rectangle `rect` (metres).
fn t_maze_with_a_pit(rect: &str) -> String {
    format!(
        "{}\n[regions]\npit = {{ rect = {rect} }}\n",
        T_MAZE.replacen("[end]\n", "[end]\nforbidden = \"in pit\"\n", 1)
    )
}

#[test]
fn entering_a_forbidden_region_ends_the_sample_as_a_wrong_branch() {
    // A pit over the stem's third cell: the robot driving straight up falls in before it
    // reaches the junction's wall.
    let text = t_maze_with_a_pit("[-0.15, 0.45, 0.15, 0.75]");
    let task = TaskConfig::from_scenario(Arc::new(Scenario::parse(&text, "mine.toml").unwrap()));
    let with_pit = Evaluator::new(task).unwrap();
    let without = Evaluator::new(t_maze()).unwrap();
    for variant in 0..2 {
        let sample = Sample {
            seed: 3,
            variant: Some(variant),
        };
        let fallen = with_pit.evaluate(&mut Fixed::straight(), sample);
        let crashed = without.evaluate(&mut Fixed::straight(), sample);
        assert_eq!(fallen.ending, Ending::WrongBranch, "variant {variant}");
        assert_eq!(crashed.ending, Ending::Collision, "variant {variant}");
        assert!(fallen.cycles < crashed.cycles, "{fallen:?} {crashed:?}");
        // The wrong branch's formula, a third of the progress, with less progress made.
        assert!(
            fallen.fitness > 0.0 && fallen.fitness < crashed.fitness,
            "{fallen:?} {crashed:?}"
        );
        let trace = with_pit.evaluate_traced(&mut Fixed::straight(), sample);
        let last = trace.final_robot;
        assert!(last.y > 0.45 && last.y < 0.75, "ends in the pit: {last:?}");
    }
}

#[test]
fn a_forbidden_region_that_is_unknown_or_holds_the_start_is_refused() {
    let error = edit_refusal(T_MAZE, "[end]\n", "[end]\nforbidden = \"in kitchen\"\n");
    assert!(error.contains("at `end.forbidden`"), "{error}");
    assert!(error.contains("kitchen"), "{error}");
    // A pit around the entrance, where every sample starts: it compiles, and every evaluator
    // refuses it before evaluating anything.
    let text = t_maze_with_a_pit("[-0.15, -0.15, 0.15, 0.15]");
    let task = TaskConfig::from_scenario(Arc::new(Scenario::parse(&text, "mine.toml").unwrap()));
    let error = Evaluator::new(task).expect_err("refused").to_string();
    let line = text
        .lines()
        .position(|l| l.starts_with("forbidden"))
        .unwrap()
        + 1;
    assert!(
        error.starts_with(&format!(
            "mine.toml:{line}: at `end.forbidden`: the robot starts where the scenario forbids \
             it to go: at (0."
        )),
        "{error}"
    );
}

/// The example yard with the robot placed by `place` (the `[place]` table's keys) and a
/// rectangle `middle` over the yard's lower rows and its middle obstacle.
fn yard_placed(place: &str) -> String {
    let yard = example("cross_yard");
    let edited = yard.replace(
        "[place]\nat = \"entrance\"\nfacing = \"up\"\n",
        &format!("[place]\n{place}\n"),
    );
    assert_ne!(edited, yard);
    format!("{edited}\n[regions]\nmiddle = {{ rect = [-0.9, -0.15, 0.9, 0.6] }}\n")
}

fn yard_evaluator(place: &str) -> Evaluator {
    let text = yard_placed(place);
    let scenario = Scenario::parse(&text, "mine.toml").expect("it compiles");
    Evaluator::new(TaskConfig::from_scenario(Arc::new(scenario))).expect("clear starts")
}

#[test]
fn a_start_anywhere_in_a_rectangle_is_uniform_clear_and_turned_as_asked() {
    let evaluator =
        yard_evaluator("at = \"middle\"\nfacing = \"up\"\nanywhere = true\nturn_deg = [-180, 180]");
    let radius = evaluator.task().params.robot.radius;
    let (mut xs, mut ys, mut headings) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 0..300 {
        let env = evaluator.environment(Sample::seeded(seed));
        let start = env.start;
        assert!(
            (-0.9..=0.9).contains(&start.x) && (-0.15..=0.6).contains(&start.y),
            "seed {seed}: {start:?}"
        );
        assert!(
            !env.scene.disc_hits(start.position(), radius),
            "seed {seed}: {start:?}"
        );
        assert_eq!(evaluator.environment(Sample::seeded(seed)).start, start);
        xs.push(start.x);
        ys.push(start.y);
        headings.push(start.heading);
    }
    let spread = |values: &[f32]| {
        let (min, max) = values
            .iter()
            .fold((f32::MAX, f32::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        max - min
    };
    // Over the whole rectangle, less a robot's radius or so at its walls.
    assert!(
        spread(&xs) > 1.5 && spread(&ys) > 0.5,
        "{} {}",
        spread(&xs),
        spread(&ys)
    );
    assert!(spread(&headings) > 6.0, "{}", spread(&headings));
    // Half of them on either side of the middle obstacle's column: uniform, not one spot.
    let left = xs.iter().filter(|&&x| x < 0.0).count();
    assert!((100..200).contains(&left), "{left} of 300 on the left");
}

#[test]
fn a_start_anywhere_in_a_map_region_lands_in_each_of_its_cells_facing_within_its_turn() {
    let evaluator = yard_evaluator(
        "at = \"left_bay\"\nfacing = \"down\"\nanywhere = true\nturn_deg = [-30, 30]",
    );
    let task = evaluator.task().clone();
    let map = task.scenario.map.as_ref().unwrap();
    let bay = &map.regions["left_bay"];
    assert_eq!(bay.len(), 2);
    let mut in_cell = [0; 2];
    for seed in 0..200 {
        let env = evaluator.environment(Sample::seeded(seed));
        let start = env.start;
        let cell = map.map.cell_at(start.position()).expect("in a cell");
        let idx = bay
            .iter()
            .position(|&c| c == cell)
            .expect("a cell of the bay");
        in_cell[idx] += 1;
        assert!(
            !env.scene
                .disc_hits(start.position(), task.params.robot.radius)
        );
        let down = -std::f32::consts::FRAC_PI_2;
        assert!(
            (start.heading - down).abs() <= 30f32.to_radians() + 1e-6,
            "{start:?}"
        );
    }
    assert!(in_cell.iter().all(|&n| n > 50), "{in_cell:?}");
}

#[test]
fn starts_anywhere_or_turned_that_cannot_be_are_refused_naming_the_key() {
    for (place, key, says) in [
        (
            "at = \"middle\"\nfacing = \"path\"",
            "place.facing",
            "a fixed way",
        ),
        (
            "at = \"middle\"\nfacing = \"up\"\nanywhere = true\nahead_m = 0.1",
            "place.anywhere",
            "ahead_m",
        ),
        (
            "at = \"middle\"\nfacing = \"up\"\nturn_deg = [30, -30]",
            "place.turn_deg",
            "from <= to",
        ),
        ("at = \"kitchen\"\nfacing = \"up\"", "place.at", "[regions]"),
    ] {
        let error = refusal(&yard_placed(place));
        assert!(error.contains(&format!("at `{key}`")), "{place}: {error}");
        assert!(error.contains(says), "{place}: {error}");
    }
    let (_, exit_room) = SHIPPED
        .iter()
        .find(|(name, _)| *name == "exit_room")
        .unwrap();
    let text = exit_room
        .replace("legacy", "# legacy")
        .replace("name = \"exit_room\"", "name = \"mine\"")
        .replacen("[place]\n", "[place]\nanywhere = true\n", 1);
    let error = refusal(&text);
    assert!(error.contains("at `place.anywhere`"), "{error}");
}

#[test]
fn a_world_of_solid_rectangles_alone_walls_the_robot_in() {
    let text = example("phototaxis");
    let task = TaskConfig::from_scenario(Arc::new(Scenario::parse(text, "p.toml").unwrap()));
    assert_eq!(task.scenario.solids.len(), 8);
    let evaluator = Evaluator::new(task).unwrap();
    for seed in 0..20 {
        let env = evaluator.environment(Sample::seeded(seed));
        // The rectangles are the whole world, as written.
        assert_eq!(env.scene.rects().len(), 8);
        assert!(env.ground.cells.is_none() && env.ground.room.is_none());
        // Driving straight on from anywhere along the bottom, facing any way, ends against a
        // wall or pillar, or in the pit: nothing leaves the arena.
        let outcome = evaluator.evaluate(&mut Fixed::straight(), Sample::seeded(seed));
        assert!(
            matches!(outcome.ending, Ending::Collision | Ending::WrongBranch),
            "seed {seed}: {outcome:?}"
        );
        // Spinning on the spot neither collides nor gets anywhere.
        let spun = evaluator.evaluate(&mut Fixed::spin(), Sample::seeded(seed));
        assert_eq!(spun.ending, Ending::Timeout, "seed {seed}");
    }
}

#[test]
fn solid_rectangles_join_a_map_and_a_generated_room() {
    // A block across the T-maze's stem, 0.4 m up: the robot driving straight hits it well
    // before the junction's wall.
    let blocked = T_MAZE.replacen(
        "[world]\n",
        "[world]\nsolids = [[-0.15, 0.40, 0.15, 0.45]]\n",
        1,
    );
    let task = TaskConfig::from_scenario(Arc::new(Scenario::parse(&blocked, "b.toml").unwrap()));
    let with_block = Evaluator::new(task).unwrap();
    let without = Evaluator::new(t_maze()).unwrap();
    let sample = Sample::seeded(3);
    let (hit, open) = (
        with_block.evaluate_traced(&mut Fixed::straight(), sample),
        without.evaluate(&mut Fixed::straight(), sample),
    );
    assert_eq!(hit.outcome.ending, Ending::Collision);
    assert!(
        hit.outcome.cycles < open.cycles,
        "{:?} {open:?}",
        hit.outcome
    );
    assert!(hit.final_robot.y < 0.40, "{:?}", hit.final_robot);
    assert_eq!(
        hit.rects.len(),
        without.environment(sample).scene.rects().len() + 1
    );
    // In a generated room, every sample's scene is the room's and the solid's.
    let (_, exit_room) = SHIPPED
        .iter()
        .find(|(name, _)| *name == "exit_room")
        .unwrap();
    let own_room = exit_room
        .replace("legacy", "# legacy")
        .replace("name = \"exit_room\"", "name = \"mine\"");
    let with_solid =
        own_room.replacen("[world]\n", "[world]\nsolids = [[3.0, 3.0, 3.2, 3.2]]\n", 1);
    let evaluator = |text: &str| {
        let scenario = Scenario::parse(text, "r.toml").unwrap();
        Evaluator::new(TaskConfig::from_scenario(Arc::new(scenario))).unwrap()
    };
    let (plain, solid) = (evaluator(&own_room), evaluator(&with_solid));
    for seed in 0..5 {
        let (a, b) = (
            plain.environment(Sample::seeded(seed)),
            solid.environment(Sample::seeded(seed)),
        );
        assert_eq!(b.scene.rects()[..a.scene.rects().len()], *a.scene.rects());
        assert_eq!(b.scene.rects().len(), a.scene.rects().len() + 1);
        assert_eq!(a.start, b.start, "the same draws");
    }
}

#[test]
fn bad_solid_rectangles_are_refused_naming_the_one() {
    let with =
        |solids: &str| T_MAZE.replacen("[world]\n", &format!("[world]\nsolids = {solids}\n"), 1);
    for (solids, says) in [
        ("[[0, 0, 1, 1], [1, 1, 0.5, 2]]", "at `world.solids[1]`"),
        ("[[0, 0, 1e9, 1]]", "within 50 m"),
        ("[[0, 0, 1]]", "world.solids"),
    ] {
        let error = refusal(&with(solids));
        assert!(error.starts_with("mine.toml"), "{solids}: {error}");
        assert!(error.contains(says), "{solids}: {error}");
    }
    let many = format!("[{}]", vec!["[0, 0, 0.1, 0.1]"; 1025].join(", "));
    assert!(refusal(&with(&many)).contains("at most 1024"));
}

/// The example T-maze whose right light flashes when the robot enters `zone`, a rectangle
/// across the stem from y = 0.40 to 0.50 m, instead of when it passes the light's row.
fn t_maze_with_a_zone_light(entered: &str) -> String {
    let right = "name = \"right\"\ncell = [0.33, 1.0]\ntrigger = \"passed\"\n";
    assert!(T_MAZE.contains(right));
    format!(
        "{}\n[regions]\nzone = {{ rect = [-0.15, 0.40, 0.15, 0.50] }}\n",
        T_MAZE.replace(
            right,
            &format!(
                "name = \"right\"\ncell = [0.33, 1.0]\ntrigger = {{ entered = \"{entered}\" }}\n"
            ),
        )
    )
}

#[test]
fn a_light_triggered_by_a_region_lights_when_the_robot_enters_it() {
    let text = t_maze_with_a_zone_light("zone");
    let task = TaskConfig::from_scenario(Arc::new(Scenario::parse(&text, "z.toml").unwrap()));
    let flash_cycles = task.params.light.flash_cycles as usize;
    let evaluator = Evaluator::new(task).unwrap();
    let trace = evaluator.evaluate_traced(
        &mut Fixed::straight(),
        Sample {
            seed: 3,
            variant: Some(1),
        },
    );
    let right_lit = |cycle: &hevo_sim_core::TraceCycle| cycle.lit_lights & 0b10 != 0;
    let first = trace
        .cycles
        .iter()
        .position(right_lit)
        .expect("the right light lit");
    // Lit from the first cycle that starts with the robot's centre in the zone, not before.
    assert!(
        trace.cycles[first].robot.y >= 0.40,
        "{:?}",
        trace.cycles[first].robot
    );
    assert!(trace.cycles[first - 1].robot.y < 0.40);
    let lit = trace.cycles[first..]
        .iter()
        .take_while(|c| right_lit(c))
        .count();
    // For the flash's cycles, or until the sample ended.
    assert!(
        lit == flash_cycles || first + lit == trace.cycles.len(),
        "{lit}"
    );
    // A map's region is not a rectangle the trigger can test.
    let error = refusal(&t_maze_with_a_zone_light("entrance"));
    assert!(error.contains("at `light[1].trigger.entered`"), "{error}");
    assert!(error.contains("not a [regions] rectangle"), "{error}");
}

#[test]
fn more_lights_than_a_cycle_can_mark_are_refused_and_the_most_compile() {
    let with_lights = |n_lights: usize| {
        let extra: String = (0..n_lights - 2)
            .map(|light_idx| {
                format!("[[light]]\nname = \"extra_{light_idx}\"\ncell = [0.33, 1.0]\ntrigger = \"always\"\n\n")
            })
            .collect();
        T_MAZE.replacen("[[light]]", &format!("{extra}[[light]]"), 1)
    };
    let most = hevo_sim_core::MAX_LIGHTS;
    Scenario::parse(&with_lights(most), "mine.toml").expect("the most lights compile");
    let error = refusal(&with_lights(most + 1));
    assert!(error.starts_with("mine.toml"), "{error}");
    assert!(error.contains(&format!("light[{most}]")), "{error}");
    assert!(error.contains("at most 32 lights"), "{error}");
}

#[test]
fn a_map_with_a_symbol_the_legend_lacks_is_refused() {
    let error = refusal(&T_MAZE.replace("###S###", "###S#?#"));
    assert!(error.contains("world.map"), "{error}");
    assert!(error.contains('?'), "{error}");
}

#[test]
fn only_the_shipped_files_may_claim_a_paper_task() {
    // Claiming a paper task's name would make workers run the shipped file instead.
    let (_, rescue) = SHIPPED.iter().find(|(name, _)| *name == "rescue").unwrap();
    let edited = rescue.replace("max_cycles = 2000", "max_cycles = 1500");
    let error = refusal(&edited);
    assert!(error.contains("`legacy`"), "{error}");
    assert!(error.contains("reserved"), "{error}");
    // The shipped text itself is the paper's task.
    assert_eq!(
        Scenario::parse(rescue, "rescue.toml").unwrap().legacy(),
        Some("rescue")
    );
    // A copy without the claim still may not take the paper task's name (pictures and
    // reports speak of the paper's tasks by name), nor an alias.
    let copy = edited.replace("legacy = \"rescue\"\n", "");
    let error = refusal(&copy);
    assert!(error.contains("at `name`"), "{error}");
    assert!(
        error.contains("'rescue' is the name of a scenario shipped"),
        "{error}"
    );
    let error = refusal(&copy.replace("name = \"rescue\"", "name = \"maze_single\""));
    assert!(error.contains("'maze_single'"), "{error}");
    assert!(
        Scenario::parse(
            &copy.replace("name = \"rescue\"", "name = \"my_rescue\""),
            "x"
        )
        .is_ok()
    );
}

#[test]
fn a_huge_value_is_quoted_back_bounded() {
    let long = "x".repeat(100_000);
    let error = refusal(&T_MAZE.replace("name = \"t_maze\"", &format!("name = \"{long}\"")));
    assert!(error.len() < 2_000, "{} bytes", error.len());
}

#[test]
fn bad_teammates_are_refused_naming_the_key() {
    for (from, to, key, expected) in [
        (
            "behaviour = \"wander\"",
            "behaviour = \"dance\"",
            "teammate.behaviour",
            "'dance' is not follow, fixed or wander",
        ),
        (
            "behaviour = \"wander\"",
            "behaviour = \"wander\"\nfollowing = true",
            "teammate.following",
            "would never wander",
        ),
        (
            "placement = \"centre\"\n",
            "",
            "teammate.placement",
            "placement = \"centre\"",
        ),
        (
            "at = \"den\"",
            "at = \"lair\"",
            "teammate.at",
            "'lair' is not goal, start or a region of the map",
        ),
        (
            "otherwise = \"approach teammate / 2\"",
            "otherwise = \"approach teammate / 2\"\n[teammate]\nat = \"den\"",
            "",
            "duplicate key",
        ),
    ] {
        let error = edit_refusal(FIND_WANDERER, from, to);
        assert!(error.contains(key), "{to}: {error}");
        assert!(error.contains(expected), "{to}: {error}");
    }
    // Without a teammate, neither its ending nor its approach means anything.
    let alone: String = FIND_WANDERER
        .split("[teammate]")
        .next()
        .unwrap()
        .to_string()
        + &FIND_WANDERER[FIND_WANDERER.find("[end]").unwrap()..];
    let error = refusal(&alone);
    assert!(error.contains("end.solved"), "{error}");
    let error = refusal(&T_MAZE.replace("timeout = \"0\"", "timeout = \"approach teammate\""));
    assert!(error.contains("fitness.timeout"), "{error}");
    assert!(
        error.contains("'approach teammate': needs a [teammate]"),
        "{error}"
    );
}

/// The room under a corridor: every sample's room has its exit centred under the corridor's
/// first cell, on the corridor's lower border, the robot starts in the room clear of every
/// solid, and the goal is the corridor's end, reached through the exit.
#[test]
fn a_room_joins_a_corridor_below_its_first_cell() {
    let scenario = Scenario::parse(ROOM_TO_CORRIDOR, "room_to_corridor.toml").unwrap();
    let task = TaskConfig::from_scenario(Arc::new(scenario));
    assert_eq!(task.validate(), Ok(()));
    // The corridor's shape is what a sample reports, as for turn_left.
    assert_eq!(task.scenario.reported_variants(), 3);
    let evaluator = Evaluator::new(task.clone()).unwrap();
    let mut shapes = std::collections::BTreeSet::new();
    for seed in 0..40 {
        let env = evaluator.environment(Sample::seeded(seed));
        let room = env.ground.room.as_ref().expect("a room");
        let goal = env.ground.goal.as_ref().expect("a corridor goal");
        let first = goal.map.center(0);
        // The first cell's lower border is half a 0.30 m cell below its centre; the room's
        // exit is on the inner face of a 0.10 m wall centred on it.
        let exit_y = first[1] - 0.15 - 0.05;
        assert!((room.exit_center[0] - first[0]).abs() < 1e-5, "seed {seed}");
        assert!((room.exit_center[1] - exit_y).abs() < 1e-5, "seed {seed}");
        assert_eq!(room.exit_outward, [0.0, 1.0]);
        assert!(
            !env.scene
                .disc_hits(env.start.position(), task.params.robot.radius),
            "seed {seed}: the start touches a solid"
        );
        assert!(
            env.start.y < exit_y,
            "seed {seed}: the start is in the room"
        );
        // The corridor's first cell opens downwards into the room: a point in the gap is free.
        assert!(
            !env.scene.disc_hits([first[0], exit_y], 0.05),
            "seed {seed}"
        );
        assert!(goal.map.cell_at(env.start.position()).is_none());
        shapes.insert(env.variant);
    }
    assert_eq!(shapes.len(), 3, "every shape comes up: {shapes:?}");
    // A robot driving straight from the room's start ends in a collision or a timeout, never
    // solved: the turn is needed.
    let outcome = evaluator.evaluate(&mut Fixed::straight(), Sample::seeded(3));
    assert_ne!(outcome.ending, Ending::Solved);
}

#[test]
fn corridors_join_only_below_a_room() {
    for (from, to, key, expected) in [
        (
            "room = \"below corridor\"",
            "room = \"standalone\"",
            "world.room",
            "\"below corridor\"",
        ),
        (
            "room = \"below corridor\"",
            "room = \"below entrance\"",
            "world.room",
            "a room with a corridor is \"below corridor\"",
        ),
        (
            "room = \"below corridor\"",
            "room = \"below corridor\"\nmap = \"double_t_maze\"",
            "world.corridor",
            "do not join",
        ),
        (
            "room = \"below corridor\"\ncorridor = \"left\"",
            "room = \"below corridor\"",
            "world.room",
            "needs a corridor",
        ),
        (
            "corridor = \"left\"",
            "corridor = \"up\"",
            "world.corridor",
            "'up' is not straight, left or right",
        ),
    ] {
        let error = edit_refusal(ROOM_TO_CORRIDOR, from, to);
        assert!(error.contains(key), "{to}: {error}");
        assert!(error.contains(expected), "{to}: {error}");
    }
}

/// The generators' exit and corridor ends are drawn but not judged: a condition naming one is
/// refused with the reason, not left to never hold.
#[test]
fn conditions_naming_undrawable_generator_regions_are_refused() {
    for name in ["corridor.end", "corridor.start", "room.exit"] {
        let text = format!(
            "{ROOM_TO_CORRIDOR}\n[[stage]]\nname = \"up the corridor\"\nreached = \"in {name}\"\n"
        );
        let message = refusal(&text);
        assert!(
            message.contains("stage")
                && message.contains(&format!("conditions cannot test '{name}'")),
            "{message}"
        );
    }
    let message = refusal(&format!(
        "{ROOM_TO_CORRIDOR}\n[[stage]]\nname = \"kitchen\"\nreached = \"in kitchen\"\n"
    ));
    assert!(
        message.contains("no region is named 'kitchen'"),
        "{message}"
    );
}

/// A scenario on an open square map of `side` x `side` cells of `cell_size` metres.
fn open_map(side: usize, cell_size: &str) -> String {
    let row = ".".repeat(side);
    let grid: Vec<&str> = std::iter::repeat_n(row.as_str(), side).collect();
    format!(
        "schema = \"hevo.scenario/1\"\nname = \"open\"\nmax_cycles = 100\n\n[world]\n\
         map = {{ cell_size = {cell_size}, wall_thickness = 0.10, origin = [0, 0], grid = \"\"\"\n\
         S{}\n{}\n\"\"\", legend = {{ \".\" = \"open\", S = \"home\" }} }}\n\n\
         [place]\nat = \"home\"\nfacing = \"up\"\n\n[end]\nsolved = \"always\"\n\n\
         [fitness]\nsolved = \"1\"\notherwise = \"0\"\n",
        &row[1..],
        grid[1..].join("\n")
    )
}

#[test]
fn a_map_too_large_or_too_far_out_is_refused_before_its_cells_are_built() {
    // Open maps up to the limit compile (in time linear in their cells).
    Scenario::parse(&open_map(100, "0.30"), "mine.toml").expect("a 100 x 100 map");
    Scenario::parse(&open_map(128, "0.30"), "mine.toml").expect("a 128 x 128 map");
    let error = refusal(&open_map(1000, "0.30"));
    assert!(
        error.contains("at `world.map.grid`")
            && error.contains("1000 rows x 1000 columns")
            && error.contains("at most 16384"),
        "{error}"
    );
    let error = refusal(&open_map(3, "1e9"));
    assert!(
        error.contains("at `world.map.cell_size`") && error.contains("at most 10"),
        "{error}"
    );
    let error = refusal(&open_map(100, "1.0"));
    assert!(
        error.contains("at `world.map.origin`") && error.contains("at most 50 m"),
        "{error}"
    );
    let huge = format!("{T_MAZE}\n# {}\n", "x".repeat(1024 * 1024));
    assert!(refusal(&huge).contains("bytes, at most 1048576"));
}

#[test]
fn numbers_that_are_not_finite_or_out_of_range_are_refused_naming_the_key() {
    for (from, to, key) in [
        ("timeout = \"0\"", "timeout = \"nan\"", "fitness.timeout"),
        ("timeout = \"0\"", "timeout = \"inf\"", "fitness.timeout"),
        ("timeout = \"0\"", "timeout = \"1e40\"", "fitness.timeout"),
        (
            "solved = \"1 + time_bonus\"",
            "solved = \"1 + time_bonus / 1e-40\"",
            "fitness.solved",
        ),
        ("cell = [-0.33, 1.0]", "cell = [nan, 1.0]", "light[0].cell"),
        ("cell = [0.33, 1.0]", "cell = [0.33, inf]", "light[1].cell"),
        ("cell = [0.33, 1.0]", "cell = [0.33, 1e6]", "light[1].cell"),
        (
            "facing = \"up\"",
            "facing = \"up\"\nahead_m = nan",
            "place.ahead_m",
        ),
        (
            "facing = \"up\"",
            "facing = \"up\"\nahead_m = 1e30",
            "place.ahead_m",
        ),
        (
            "wrong_branch = \"off path\"",
            "wrong_branch = \"off path\"\nnear_m = -0.1",
            "end.near_m",
        ),
    ] {
        let error = edit_refusal(T_MAZE, from, to);
        assert!(error.contains(&format!("at `{key}`")), "{to}: {error}");
    }
    let room = Scenario::shipped("exit_room").unwrap().source.replace(
        "name = \"exit_room\"\nlegacy = \"exit_room\"\n",
        "name = \"my_room\"\n",
    );
    // The room's numbers are the task's, checked when a task is made from the scenario.
    let huge_room = room.replace("[world]", "[room]\nmax_side = 1e9\n\n[world]");
    let scenario = Arc::new(Scenario::parse(&huge_room, "mine.toml").expect("it compiles"));
    let error = Evaluator::new(TaskConfig::from_scenario(scenario))
        .expect_err("refused")
        .to_string();
    assert!(
        error.contains("room.max_side") && error.contains("at most 20 m"),
        "{error}"
    );
}

#[test]
fn a_start_outside_every_open_cell_of_a_map_is_refused() {
    // The start cell's centre moved a cell and a half ahead: into the solid cells beside the
    // stem's end, where no wall is near (walls lie only between open and solid cells).
    let text = T_MAZE.replace(
        "at = \"entrance\"\nfacing = \"up\"",
        "at = \"entrance\"\nfacing = \"right\"\nahead_m = 0.6",
    );
    let scenario = Arc::new(Scenario::parse(&text, "mine.toml").expect("it compiles"));
    let error = Evaluator::new(TaskConfig::from_scenario(scenario))
        .expect_err("refused")
        .to_string();
    assert!(
        error.contains("at `place`: the robot starts outside every open cell of the map"),
        "{error}"
    );
}

#[test]
fn a_huge_unknown_key_is_quoted_only_in_part() {
    let key = "k".repeat(16_000);
    let error = edit_refusal(
        T_MAZE,
        "max_cycles = 500",
        &format!("max_cycles = 500\n{key} = 1"),
    );
    assert!(error.contains("kkkk"), "{error}");
    assert!(error.len() < 2_000, "{} characters", error.len());
}

#[test]
fn the_authors_room_keys_are_checked_before_any_room_is_drawn() {
    let authors = example("exit_room_authors");
    // A count per area beyond the bound: refused by the task's check, naming the key.
    let scenario = Scenario::parse(
        &authors.replace("obstacles_per_m2 = 3.0", "obstacles_per_m2 = 1e9"),
        "mine.toml",
    )
    .expect("the file's syntax is fine");
    let error = TaskConfig::from_scenario(Arc::new(scenario))
        .validate()
        .unwrap_err()
        .to_string();
    assert!(
        error.starts_with("room.obstacles_per_m2 ") && error.contains("at most 64 obstacles"),
        "{error}"
    );
    // A placement that does not exist: refused by the parser, naming the key and the line.
    let error = edit_refusal(
        authors,
        "obstacle_placement = \"jbotevolver\"",
        "obstacle_placement = \"anywhere\"",
    );
    assert!(
        error.contains("at `room.obstacle_placement`")
            && error.contains("expected one of `spaced`, `uniform`, `jbotevolver`"),
        "{error}"
    );
}

/// The TOML blocks of docs/scenario-file.md, as a reader copies them (the list item's
/// indentation taken off).
fn scenario_doc_toml_blocks() -> Vec<String> {
    let doc = include_str!("../../../docs/scenario-file.md");
    let mut blocks = Vec::new();
    let mut open: Option<(usize, String)> = None;
    for line in doc.lines() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        match (&mut open, trimmed) {
            (None, "```toml") => open = Some((indent, String::new())),
            (Some(_), "```") => blocks.push(open.take().unwrap().1),
            (Some((indent, block)), _) => {
                *block += line.get(*indent..).unwrap_or("");
                *block += "\n";
            }
            (None, _) => {}
        }
    }
    blocks
}

#[test]
fn the_docs_room_block_is_the_authors_room_of_the_example() {
    let authors = example("exit_room_authors");
    let room_block = scenario_doc_toml_blocks()
        .into_iter()
        .find(|block| block.starts_with("[room]"))
        .expect("docs/scenario-file.md shows a [room] block");
    // The example with its own [room] table replaced by the docs' block.
    let (head, rest) = authors.split_at(authors.find("[room]").unwrap());
    let tail = &rest[rest.find("[world]").unwrap()..];
    let from_docs = format!("{head}{room_block}\n{tail}");
    let scenario = Scenario::parse(&from_docs, "docs.toml").unwrap_or_else(|e| panic!("{e}"));
    let task = TaskConfig::from_scenario(Arc::new(scenario));
    assert_eq!(task.validate(), Ok(()));
    assert_eq!(
        task.params.room,
        example_task("exit_room_authors").params.room
    );
}

#[test]
fn the_docs_file_group_block_is_the_mixed_aggregation_examples() {
    let block = scenario_doc_toml_blocks()
        .into_iter()
        .find(|block| block.contains("controller = { file"))
        .expect("docs/scenario-file.md shows a group that runs a controller file");
    let example = include_str!("../../../scenarios/swarm/mixed_aggregation.toml");
    assert!(example.contains(&block), "{block}");
}

/// An open arena 2 m wide, the robot at its centre facing east; `end` is the `[end]` table.
fn arena_with_regions(end: &str) -> TaskConfig {
    let text = format!(
        r#"schema = "hevo.scenario/1"
name = "arena"
max_cycles = 400

[world]
solids = [
    [-1.05, -1.05, 1.05, -1.0],
    [-1.05, 1.0, 1.05, 1.05],
    [-1.05, -1.0, -1.0, 1.0],
    [1.0, -1.0, 1.05, 1.0],
]

[regions]
middle = {{ rect = [-0.1, -0.1, 0.1, 0.1] }}
west = {{ rect = [-0.9, -0.2, -0.5, 0.2] }}
east = {{ rect = [0.5, -0.2, 0.9, 0.2] }}
north = {{ rect = [-0.2, 0.5, 0.2, 0.9] }}

[place]
at = "middle"
facing = "right"

[end]
{end}

[fitness]
solved = "1"
otherwise = "0"
"#
    );
    TaskConfig::from_scenario(Arc::new(
        Scenario::parse(&text, "arena.toml").unwrap_or_else(|e| panic!("{e}")),
    ))
}

#[test]
fn or_joins_clauses_of_atoms_joined_by_and() {
    // The robot drives east from the centre for 120 cycles (0.72 m) into `east` and stops
    // there, never in `west` or `north`.
    for (end, ending) in [
        (r#"solved = "in east""#, Ending::Solved),
        (r#"solved = "in west""#, Ending::Timeout),
        (r#"solved = "in west or in east""#, Ending::Solved),
        (r#"solved = "in east or in west""#, Ending::Solved),
        (r#"solved = "in west or in north""#, Ending::Timeout),
        // `and` binds tighter: (in west and in east) or in east.
        (
            r#"solved = "in west and in east or in east""#,
            Ending::Solved,
        ),
        // in west and (in east or in east) would never hold.
        (
            r#"solved = "in east and in west or in north""#,
            Ending::Timeout,
        ),
        (r#"solved = "not in east or in west""#, Ending::Solved),
        (
            "solved = \"in north\"\nforbidden = \"in west or in east\"",
            Ending::WrongBranch,
        ),
    ] {
        let evaluator = Evaluator::new(arena_with_regions(end)).unwrap();
        let outcome = evaluator.evaluate(&mut Fixed::new([0.8, 0.8], 120), Sample::seeded(0));
        assert_eq!(outcome.ending, ending, "{end}");
    }
    // The east is reached after some cycles, not at once: `not in east` holds at the first.
    let evaluator = Evaluator::new(arena_with_regions(r#"solved = "in east""#)).unwrap();
    let outcome = evaluator.evaluate(&mut Fixed::new([0.8, 0.8], 120), Sample::seeded(0));
    assert!(outcome.cycles > 20, "{}", outcome.cycles);
}

#[test]
fn distance_and_energy_follow_the_wheels() {
    let task = arena_with_regions(
        "solved = \"in north\"\n\n[descriptor]\nquantities = [\"distance\", \"energy\", \"final.x\"]",
    );
    let evaluator = Evaluator::new(task).unwrap();
    let max_cycles = 400.0;
    let v_max = 0.1;
    let step = v_max * 0.1;
    // Wheels at 0.6 of full speed for 120 cycles, then still: 0.72 m travelled (5 % wheel
    // noise either way), straight ahead, and 0.6 x 120 / 400 = 0.18 of the energy.
    let outcome = evaluator.evaluate(&mut Fixed::new([0.8, 0.8], 120), Sample::seeded(3));
    let [distance, energy, final_x] = outcome.descriptor[..] else {
        panic!("{:?}", outcome.descriptor)
    };
    assert_eq!(outcome.ending, Ending::Timeout);
    assert!((distance - 0.6 * step * 120.0).abs() < 0.02, "{distance}");
    assert!(
        distance >= final_x && distance - final_x < 0.01,
        "{distance} {final_x}"
    );
    assert!(
        (energy - 0.6 * 120.0 / max_cycles).abs() < 0.005,
        "{energy}"
    );
    // Spinning on the spot: full speed, the wheels opposed; the centre hardly moves (the wheel
    // noise makes it wander a few centimetres, against the 4 m of driving straight as long).
    let outcome = evaluator.evaluate(&mut Fixed::new([1.0, 0.0], u32::MAX), Sample::seeded(3));
    let [distance, energy, _] = outcome.descriptor[..] else {
        panic!("{:?}", outcome.descriptor)
    };
    assert!(distance < 0.1, "{distance}");
    assert!(energy > 0.95 && energy <= 1.0, "{energy}");
    // Standing still: nothing at all.
    let outcome = evaluator.evaluate(&mut Fixed::new([0.5, 0.5], u32::MAX), Sample::seeded(3));
    assert_eq!(outcome.descriptor, [0.0, 0.0, 0.0]);
    // Into the east wall at full speed: the moves a collision undid count nothing.
    let crash = arena_with_regions(
        "solved = \"in north\"\n\n[descriptor]\nquantities = [\"distance\", \"final.x\"]",
    );
    let outcome = Evaluator::new(crash)
        .unwrap()
        .evaluate(&mut Fixed::straight(), Sample::seeded(3));
    assert_eq!(outcome.ending, Ending::Collision);
    let [distance, final_x] = outcome.descriptor[..] else {
        panic!("{:?}", outcome.descriptor)
    };
    assert!(
        distance >= final_x && distance - final_x < 0.01,
        "{distance} {final_x}"
    );
}

#[test]
fn a_random_maze_is_drawn_per_sample_with_its_goal_reachable_from_the_start() {
    let evaluator = Evaluator::new(example_task("random_maze")).unwrap();
    let mut layouts = std::collections::BTreeSet::new();
    for seed in 0..40 {
        let env = evaluator.environment(Sample::seeded(seed));
        let goal = env.ground.goal.as_ref().expect("a goal in cells");
        assert_eq!(goal.map.cells.len(), 36);
        // The goal, the top-right cell, is a finite corridor distance from every cell.
        assert_eq!(goal.map.cells[goal.goal].at, [5, 5]);
        assert!(goal.distances.iter().all(|d| d.is_finite()), "seed {seed}");
        // The robot starts in the bottom-left cell, on the path, touching nothing.
        let start_cell = goal.map.cell_at([env.start.x, env.start.y]);
        assert_eq!(start_cell, Some(0), "seed {seed}");
        assert!(goal.on_path[0] && goal.on_path[goal.goal]);
        assert!(!env.scene.disc_hits([env.start.x, env.start.y], 0.0375));
        // The same seed, the same maze.
        let again = evaluator.environment(Sample::seeded(seed));
        let walls: Vec<[bool; 4]> = goal.map.cells.iter().map(|c| c.walls).collect();
        let again_goal = again.ground.goal.as_ref().unwrap();
        let walls_again: Vec<[bool; 4]> = again_goal.map.cells.iter().map(|c| c.walls).collect();
        assert_eq!(walls, walls_again);
        layouts.insert(walls);
    }
    assert_eq!(layouts.len(), 40, "each seed its own maze");
}

#[test]
fn a_corridor_beyond_a_map_is_drawn_per_sample_and_reached_through_the_map() {
    let evaluator = Evaluator::new(example_task("map_to_corridor")).unwrap();
    let n_map_cells = 6;
    let mut shapes = std::collections::BTreeSet::new();
    for seed in 0..40 {
        let env = evaluator.environment(Sample::seeded(seed));
        let goal = env.ground.goal.as_ref().expect("a goal in cells");
        let map = &goal.map;
        // The map's cells keep their places and indices; the corridor's follow, every one of
        // them right of the map's exit column, and its first cell opens onto the exit.
        assert_eq!(
            map.cells[..n_map_cells]
                .iter()
                .map(|c| c.at)
                .collect::<Vec<_>>(),
            [[0, 4], [0, 3], [1, 3], [2, 3], [0, 2], [0, 1]]
        );
        assert!(
            map.cells[n_map_cells..].iter().all(|c| c.at[0] > 2),
            "seed {seed}"
        );
        assert!(map.neighbours(3).any(|n| n == n_map_cells), "seed {seed}");
        // The way runs from the entrance through the exit to the corridor's end, every cell
        // finitely far from the goal; the map's dead end is off it.
        let start_cell = map.cell_at([env.start.x, env.start.y]);
        assert_eq!(start_cell, Some(5), "seed {seed}");
        for cell in [5, 4, 1, 2, 3, n_map_cells, goal.goal] {
            assert!(goal.on_path[cell], "seed {seed}: cell {cell}");
        }
        assert!(!goal.on_path[0], "seed {seed}: the dead end");
        assert!(goal.goal >= n_map_cells);
        assert!(goal.distances.iter().all(|d| d.is_finite()), "seed {seed}");
        assert!(!env.scene.disc_hits([env.start.x, env.start.y], 0.0375));
        shapes.insert(env.variant);
        // The same seed, the same corridor.
        let again = evaluator.environment(Sample::seeded(seed));
        let again_map = &again.ground.goal.as_ref().unwrap().map;
        assert_eq!(map.cells, again_map.cells);
    }
    assert_eq!(shapes.len(), 2, "an L-bend and a T-junction: {shapes:?}");
}

#[test]
fn a_corridor_beyond_a_map_needs_an_outermost_exit_and_no_other_goal() {
    let text = example("map_to_corridor");
    for (from, to, key, wanted) in [
        (
            "E = \"exit\"",
            "E = \"way_out\"",
            "world.corridor",
            "the map's one-cell region 'exit'",
        ),
        (
            "D##\n..E",
            "D#E\n...",
            "world.corridor",
            "must be outermost on exactly one side",
        ),
        (
            "cell_size = 0.30",
            "cell_size = 0.40",
            "world.map",
            "a corridor joins a map of 0.3 m cells",
        ),
        (
            "D##\n..E",
            "D##\n#.E",
            "world.corridor",
            "no way leads from the start 'entrance' to the map's exit",
        ),
        (
            "corridor = \"left\"",
            "corridor = \"left\"\nroom = \"standalone\"",
            "world.corridor",
            "a map, a room and a corridor do not join",
        ),
        (
            "[place]",
            "[[variant]]\nname = \"one\"\ngoal = \"dead_end\"\n\n[place]",
            "variant[0].goal",
            "the goal of a corridor beyond a map is the corridor's end",
        ),
    ] {
        let error = edit_refusal(text, from, to);
        assert!(
            error.contains(&format!("at `{key}`")) && error.contains(wanted),
            "{to}: {error}"
        );
    }
}

#[test]
fn a_random_maze_of_no_size_or_beside_another_world_is_refused() {
    let maze = example("random_maze");
    for (to, wanted) in [
        (
            "maze = { cols = 0, rows = 6 }",
            "at `world.maze.cols`: 0 cells: a random maze has 1 to 32 a side",
        ),
        (
            "maze = { cols = 6, rows = 33 }",
            "at `world.maze.rows`: 33 cells",
        ),
        (
            "maze = { cols = 1, rows = 1 }",
            "at `world.maze`: a maze of one cell has no way to its goal",
        ),
        (
            "maze = { cols = 6, rows = 6 }\ncorridor = \"left\"",
            "at `world.maze`: a random maze stands alone",
        ),
        ("maze = { cols = 6 }", "missing field `rows`"),
    ] {
        let error = edit_refusal(maze, "maze = { cols = 6, rows = 6 }", to);
        assert!(error.contains(wanted), "{to}: {error}");
    }
}
