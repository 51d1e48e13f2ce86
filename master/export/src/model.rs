//! The controller tree and the task as the exported C needs them: the tree flattened in
//! pre-order (the node order of sim-core's `Controller`), each network's parameters decoded
//! from its genome exactly as `Ctrnn::new` decodes them (weight rows per receiving neuron,
//! `dt / tau` from sim-core's own `tau_from_gene`, the rest firing `logistic(theta)`), and the
//! input side's constants (the IR inverse table, the flash thresholds, which groups are live).

use hevo_sim_core::TaskConfig;
use hevo_sim_core::{ControllerFile, NodeKind, NodeSpec};
use hevo_sim_core::{InputGroup, N_FLAT};
use hevo_sim_core::{IrMapping, IrModel, LightModel, N_IR, N_LIGHT};
use hevo_sim_core::{logistic, tau_from_gene};

use crate::ExportError;

/// One node of the flattened tree, with its network's parameters ready to emit.
#[derive(Debug, Clone)]
pub struct NodeModel {
    /// Path from the root, e.g. `rescue/solve_maze/turn_left`.
    pub path: String,
    /// Whether it chooses among children (else it drives the wheels).
    pub is_arbitrator: bool,
    /// For each network input, its index in the frame (`hevo_state.inputs`).
    pub input_index: Vec<usize>,
    /// Hidden neurons.
    pub n_hidden: usize,
    /// Outputs: two for a primitive, one per child for an arbitrator.
    pub n_outputs: usize,
    /// `n_hidden` rows of `n_inputs + n_hidden`: the input weights, then the recurrent ones.
    pub hidden_weights: Vec<f32>,
    /// theta, per hidden neuron.
    pub hidden_biases: Vec<f32>,
    /// `dt * (1 / tau)`, per hidden neuron, as sim-core computes it.
    pub dt_over_tau: Vec<f32>,
    /// `logistic(theta)`, per hidden neuron.
    pub rest_firing: Vec<f32>,
    /// `n_outputs` rows of `n_hidden`.
    pub output_weights: Vec<f32>,
    /// One per output.
    pub output_biases: Vec<f32>,
    /// Node indices of the children, in output order.
    pub children: Vec<usize>,
    /// One past the last node index of this node's sub-tree.
    pub subtree_end: usize,
    /// Arbitrators: cycles a child stays on once switched on.
    pub min_active_cycles: u32,
    /// Depth below the root (the root is 0).
    pub depth: usize,
}

impl NodeModel {
    /// Number of network inputs.
    pub fn n_inputs(&self) -> usize {
        self.input_index.len()
    }
}

/// The IR side: the average curve's inverse table.
#[derive(Debug, Clone)]
pub struct IrSide {
    /// Mean raw reading at each grid distance, non-increasing.
    pub means: Vec<f32>,
    /// Grid step, metres.
    pub step: f32,
    /// The grid's farthest distance, metres.
    pub max_distance: f32,
}

/// How many inputs of the frame the generated C holds (`HEVO_N_INPUTS`): ir (4), light (2),
/// near_robot (1), the frame's first groups. A group after them (`rab`, `items`) is not
/// exported.
pub const EXPORTED_INPUTS: usize = N_IR + N_LIGHT + 1;

/// The groups the generated C fills, in frame order.
pub const EXPORTED_GROUPS: [InputGroup; 3] =
    [InputGroup::IR, InputGroup::LIGHT, InputGroup::NEAR_ROBOT];

/// Everything the generated C needs.
#[derive(Debug, Clone)]
pub struct ExportModel {
    /// The root node's name.
    pub controller_name: String,
    /// The task's name.
    pub task_name: String,
    /// The nodes in pre-order.
    pub nodes: Vec<NodeModel>,
    /// Control cycle, seconds.
    pub dt: f32,
    /// Wheel speed at output 1, metres per second.
    pub v_max: f32,
    /// Range of the near-robot flag, metres.
    pub near_robot_range: f32,
    /// Whether the task's robot reads each group (ir, light, near_robot); the others read 0.
    pub live: [bool; 3],
    /// The IR inverse table.
    pub ir: IrSide,
    /// Per side: a raw ambient reading below it is a flash.
    pub light_threshold: [f32; N_LIGHT],
    /// Per side: the raw reading in the dark (the calibration's farthest row).
    pub light_dark: [f32; N_LIGHT],
    /// Cycles a light input stays 1 after a flash.
    pub light_hold: u32,
}

impl ExportModel {
    /// The model of a complete controller file (no free node) on `task`.
    pub fn new(file: &ControllerFile, task: &TaskConfig) -> Result<ExportModel, ExportError> {
        file.validate()?;
        if let Some((path, _)) = file.free_node_topology() {
            return Err(ExportError::FreeNode { path });
        }
        check_frame_layout()?;
        check_groups_read(&file.root, &file.root.name)?;
        if task.params.ir.mapping != IrMapping::AverageTable {
            return Err(ExportError::Unsupported(format!(
                "the task's ir.mapping is {:?}; only the default average_table is exported",
                task.params.ir.mapping
            )));
        }
        let dt = task.params.robot.cycle_seconds;
        let mut nodes: Vec<NodeModel> = Vec::new();
        // Pre-order with an explicit stack, children pushed in reverse: node indices as
        // sim-core's `Controller` numbers them (checked against `node_paths` below).
        let mut stack: Vec<(&NodeSpec, Option<usize>, usize)> = vec![(&file.root, None, 0)];
        while let Some((spec, parent, depth)) = stack.pop() {
            let node_idx = nodes.len();
            let path = match parent {
                Some(parent) => format!("{}/{}", nodes[parent].path, spec.name),
                None => spec.name.clone(),
            };
            if let Some(parent) = parent {
                nodes[parent].children.push(node_idx);
            }
            nodes.push(decode_node(spec, path, depth, dt)?);
            for child in spec.children.iter().rev() {
                stack.push((child, Some(node_idx), depth + 1));
            }
        }
        for node_idx in (0..nodes.len()).rev() {
            nodes[node_idx].subtree_end = match nodes[node_idx].children.last() {
                Some(&last) => nodes[last].subtree_end,
                None => node_idx + 1,
            };
        }
        let paths: Vec<&str> = nodes.iter().map(|n| n.path.as_str()).collect();
        if paths != file.node_paths() {
            return Err(ExportError::Unsupported(
                "sim-core numbers the tree's nodes in another order than pre-order".into(),
            ));
        }
        if nodes.len() > usize::from(u16::MAX) {
            return Err(ExportError::Unsupported(format!(
                "the tree has {} nodes, more than 65535",
                nodes.len()
            )));
        }

        let (means, step, max_distance) = IrModel::builtin().inverse_table();
        let light_model = LightModel::builtin();
        let dark = |side: usize| light_model.dark(side).map_or(f32::INFINITY, |d| d.mean);
        let live = EXPORTED_GROUPS.map(|group| {
            task.scenario.sensors.carries(group)
                && (group.kind().compile)(&task.params, &task.scenario.sensed_world()).is_some()
        });
        Ok(ExportModel {
            controller_name: file.root.name.clone(),
            task_name: task.name().to_string(),
            nodes,
            dt,
            v_max: task.params.robot.v_max,
            near_robot_range: task.params.robot.near_robot_range,
            live,
            ir: IrSide {
                means: means.to_vec(),
                step,
                max_distance,
            },
            light_threshold: task.params.light.threshold_raw,
            light_dark: [dark(0), dark(1)],
            light_hold: task.params.light.hold_cycles,
        })
    }

    /// The longest root-to-primitive path, in nodes.
    pub fn max_path(&self) -> usize {
        self.nodes.iter().map(|n| n.depth + 1).max().unwrap_or(1)
    }

    /// Hidden neurons over all nodes.
    pub fn n_hidden_total(&self) -> usize {
        self.nodes.iter().map(|n| n.n_hidden).sum()
    }

    /// Presynaptic slots (inputs and hidden) over all nodes.
    pub fn n_presyn_total(&self) -> usize {
        self.nodes.iter().map(|n| n.n_inputs() + n.n_hidden).sum()
    }

    /// Outputs over all nodes.
    pub fn n_outputs_total(&self) -> usize {
        self.nodes.iter().map(|n| n.n_outputs).sum()
    }

    /// Network parameters over all nodes.
    pub fn n_parameters(&self) -> usize {
        self.nodes
            .iter()
            .map(|n| {
                n.hidden_weights.len()
                    + n.hidden_biases.len()
                    + n.dt_over_tau.len()
                    + n.output_weights.len()
                    + n.output_biases.len()
            })
            .sum()
    }
}

/// The generated C reads the frame as ir (4), light (2), near_robot (1), its first groups; a
/// sim-core whose sensor registry has changed them needs the generator changed too. Groups
/// registered after them leave these in place and are refused where a node reads them
/// ([`check_groups_read`]).
fn check_frame_layout() -> Result<(), ExportError> {
    let expected = [
        (InputGroup::IR, 0..N_IR),
        (InputGroup::LIGHT, N_IR..N_IR + N_LIGHT),
        (InputGroup::NEAR_ROBOT, N_IR + N_LIGHT..EXPORTED_INPUTS),
    ];
    let fits = expected
        .iter()
        .all(|(group, range)| group.flat_range() == *range)
        && InputGroup::ALL[..EXPORTED_GROUPS.len()] == EXPORTED_GROUPS
        && N_FLAT >= EXPORTED_INPUTS;
    if fits {
        Ok(())
    } else {
        Err(ExportError::Unsupported(format!(
            "sim-core's frame holds {:?}; the exporter knows ir, light and near_robot first",
            InputGroup::ALL
        )))
    }
}

/// Refuses a tree with a node that reads a group the generated C does not fill: the C has no
/// driver for the sensor (`rab`: the range-and-bearing board's firmware side is not written;
/// `items`: the camera's item detection is not written),
/// so the node would read 0 on the robot where sim-core gave it readings.
fn check_groups_read(root: &NodeSpec, root_path: &str) -> Result<(), ExportError> {
    let mut stack = vec![(root, root_path.to_string())];
    while let Some((spec, path)) = stack.pop() {
        if let Some(group) = spec
            .inputs
            .iter()
            .find(|group| !EXPORTED_GROUPS.contains(group))
        {
            return Err(ExportError::Unsupported(format!(
                "{path} reads '{group}', a sensor the C export does not produce (it fills ir, \
                 light and near_robot only; docs/export.md)"
            )));
        }
        for child in &spec.children {
            stack.push((child, format!("{path}/{}", child.name)));
        }
    }
    Ok(())
}

/// One node's network decoded from its genome as `Ctrnn::new` decodes it.
fn decode_node(
    spec: &NodeSpec,
    path: String,
    depth: usize,
    dt: f32,
) -> Result<NodeModel, ExportError> {
    let topology = spec.topology();
    let genes = spec.genome.as_deref().unwrap_or_default();
    let layout = topology.layout();
    let (n_in, n_hid, n_out) = (topology.n_inputs, topology.n_hidden, topology.n_outputs);
    if n_in > 255 || n_hid > 255 || n_out > 255 {
        return Err(ExportError::Unsupported(format!(
            "{path}: network {topology} has a layer wider than 255"
        )));
    }
    let input_index: Vec<usize> = spec
        .inputs
        .iter()
        .flat_map(|group| group.flat_range())
        .collect();
    let input_weights = &genes[layout.input_weights];
    let recurrent_weights = &genes[layout.hidden_weights];
    let mut hidden_weights = Vec::with_capacity(n_hid * (n_in + n_hid));
    for hidden_idx in 0..n_hid {
        hidden_weights
            .extend_from_slice(&input_weights[hidden_idx * n_in..(hidden_idx + 1) * n_in]);
        hidden_weights
            .extend_from_slice(&recurrent_weights[hidden_idx * n_hid..(hidden_idx + 1) * n_hid]);
    }
    let hidden_biases = genes[layout.hidden_biases].to_vec();
    let dt_over_tau = genes[layout.tau_genes]
        .iter()
        .map(|&gene| {
            let inv_tau = 1.0 / tau_from_gene(gene);
            dt * inv_tau
        })
        .collect();
    let rest_firing = hidden_biases.iter().map(|&theta| logistic(theta)).collect();
    Ok(NodeModel {
        path,
        is_arbitrator: spec.kind == NodeKind::Arbitrator,
        input_index,
        n_hidden: n_hid,
        n_outputs: n_out,
        hidden_weights,
        hidden_biases,
        dt_over_tau,
        rest_firing,
        output_weights: genes[layout.output_weights].to_vec(),
        output_biases: genes[layout.output_biases].to_vec(),
        children: Vec::new(),
        subtree_end: 0,
        min_active_cycles: spec.min_active_cycles,
        depth,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use hevo_sim_core::Controller;

    fn shipped(name: &str) -> ControllerFile {
        let path = format!(
            "{}/../../controllers/{name}.json",
            env!("CARGO_MANIFEST_DIR")
        );
        ControllerFile::from_json_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    }

    #[test]
    fn the_flattened_tree_is_sim_core_s() {
        let file = shipped("rescue");
        let task = TaskConfig::shipped("rescue").unwrap();
        let model = ExportModel::new(&file, &task).unwrap();
        let controller = Controller::new(&file, None).unwrap();
        assert_eq!(model.nodes.len(), controller.n_nodes());
        for (idx, node) in model.nodes.iter().enumerate() {
            assert_eq!(Some(node.path.as_str()), controller.node_path(idx));
            assert_eq!(
                Some(node.children.as_slice()),
                controller.node_children(idx)
            );
            let network = controller.node_network(idx).unwrap();
            assert_eq!(network.topology().n_hidden, node.n_hidden);
            assert_eq!(network.topology().n_inputs, node.n_inputs());
        }
        assert_eq!(model.live, [true, true, true]);
        assert_eq!(model.max_path(), 3);
        assert_eq!(model.n_parameters(), 1001);
        // exit_room has no light and no teammate: those inputs read 0.
        let exit = ExportModel::new(
            &shipped("exit_room"),
            &TaskConfig::shipped("exit_room").unwrap(),
        )
        .unwrap();
        assert_eq!(exit.live, [true, false, false]);
    }

    #[test]
    fn what_cannot_be_exported_is_refused_by_name() {
        let task = TaskConfig::shipped("solve_maze").unwrap();
        let mut file = shipped("solve_maze");
        file.root.children[1].genome = None;
        let err = ExportModel::new(&file, &task).unwrap_err();
        assert_eq!(
            err.to_string(),
            "solve_maze/turn_left: the node has no genome; only a complete controller can be exported"
        );
        let mut linear = task.clone();
        linear.params.ir.mapping = IrMapping::LinearRaw;
        let err = ExportModel::new(&shipped("solve_maze"), &linear).unwrap_err();
        assert!(err.to_string().contains("ir.mapping"), "{err}");
    }

    /// A node that reads the range-and-bearing board, at any depth, is refused by its path
    /// and the group's name: the C has no such sensor.
    #[test]
    fn a_node_reading_the_range_and_bearing_board_is_refused() {
        let task = TaskConfig::shipped("solve_maze").unwrap();
        let mut file = shipped("solve_maze");
        let child = &mut file.root.children[1];
        child.inputs.push(InputGroup::RAB);
        let n_genes = child.topology().n_genes();
        child.genome = Some(vec![0.5; n_genes]);
        let err = ExportModel::new(&file, &task).unwrap_err();
        assert_eq!(
            err.to_string(),
            "cannot export: solve_maze/turn_left reads 'rab', a sensor the C export does not \
             produce (it fills ir, light and near_robot only; docs/export.md)"
        );
        // The same tree without it exports, whatever the frame holds after near_robot.
        assert!(ExportModel::new(&shipped("solve_maze"), &task).is_ok());
        const { assert!(N_FLAT > EXPORTED_INPUTS) };
    }

    /// A node that reads the item sensor is refused as one reading the board is.
    #[test]
    fn a_node_reading_the_item_sensor_is_refused() {
        let task = TaskConfig::shipped("solve_maze").unwrap();
        let mut file = shipped("solve_maze");
        file.root.inputs.push(InputGroup::ITEMS);
        let n_genes = file.root.topology().n_genes();
        file.root.genome = Some(vec![0.5; n_genes]);
        let err = ExportModel::new(&file, &task).unwrap_err();
        assert_eq!(
            err.to_string(),
            "cannot export: solve_maze reads 'items', a sensor the C export does not produce \
             (it fills ir, light and near_robot only; docs/export.md)"
        );
    }
}
