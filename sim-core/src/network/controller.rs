//! Hierarchical controllers: behaviour primitives (networks that drive the wheels) and behaviour
//! arbitrators (networks with one output per sub-controller that activate the sub-controller with
//! the highest output), composed into trees of any depth. This module holds the versioned
//! controller file format (`hevo.controller/1`, serde JSON) with its validation and content hash,
//! and the runtime [`Controller`], which flattens a tree so that one control cycle runs without
//! recursion or allocation.
//!
//! A controller file looks like this (genomes shortened):
//!
//! ```json
//! { "schema": "hevo.controller/1",
//!   "root": { "name": "solve_maze", "kind": "arbitrator", "inputs": ["ir", "light"], "hidden": 10,
//!             "genome": null,
//!             "children": [
//!               { "name": "follow_wall", "kind": "primitive", "inputs": ["ir"], "hidden": 3,
//!                 "genome": [0.5, -3.25, ...] } ] } }
//! ```
//!
//! Every genome follows the layout documented in [`crate::network::ctrnn`]. A node whose genome is null or
//! absent is the *free* node: the one being evolved, whose genes are supplied at evaluation time.

use std::collections::HashSet;

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::math::hash::Fnv1a;
use crate::network::ctrnn::{Ctrnn, CtrnnError, CtrnnTopology, GENE_MAX, GENE_MIN};
use crate::sensors::frame::{InputGroup, SensorFrame, SensorSet};

/// The schema string of the controller file format this module reads and writes.
pub const CONTROLLER_SCHEMA: &str = "hevo.controller/1";

/// Number of outputs of a behaviour primitive: left and right wheel.
pub const PRIMITIVE_OUTPUTS: usize = 2;

/// Separator between node names in a node path such as `rescue/solve_maze/turn_left`.
pub const PATH_SEPARATOR: char = '/';

/// A whole controller file: the schema version and the tree of nodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerFile {
    /// Must be `CONTROLLER_SCHEMA` (`hevo.controller/1`).
    pub schema: String,
    /// The top of the tree.
    pub root: NodeSpec,
}

/// Whether a node drives the wheels or chooses among sub-controllers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NodeKind {
    /// A network with two outputs, left and right wheel, and no children.
    Primitive,
    /// A network with one output per child; the child with the highest output is activated.
    Arbitrator,
}

/// One node of a controller tree as stored in a file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeSpec {
    /// Unique among its siblings, so node paths are unique; it may not contain `/`, which
    /// separates names in node paths. The same name may appear under several parents.
    pub name: String,
    /// Primitive or arbitrator.
    pub kind: NodeKind,
    /// The input groups the network reads, concatenated in this order.
    pub inputs: Vec<InputGroup>,
    /// Number of hidden neurons.
    pub hidden: usize,
    /// The genome, or `None` for the free node whose genes are supplied at evaluation time.
    #[serde(default)]
    pub genome: Option<Vec<f32>>,
    /// Sub-controllers of an arbitrator, in output order; empty for a primitive.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub children: Vec<NodeSpec>,
    /// Arbitrators only: once the activator has switched a child on, it keeps it on for at
    /// least this many cycles, whatever the network's outputs say. 0 (the default, and the
    /// paper's activator) lets it switch in any cycle. The paper notes that other activators
    /// could be used; this one limits how fast an arbitrator can flick between freshly reset
    /// children (`docs/decisions/reproduction/0026-node-use.md`; return to room tried it:
    /// `docs/decisions/model/0027-min-active-cycles.md`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub min_active_cycles: u32,
}

impl NodeSpec {
    /// Every input group a node of this sub-tree reads, each once, in frame order.
    pub fn groups_read(&self) -> Vec<InputGroup> {
        let mut read = Vec::new();
        let mut stack = vec![self];
        while let Some(node) = stack.pop() {
            read.extend(&node.inputs);
            stack.extend(&node.children);
        }
        SensorSet::of(&read).groups().collect()
    }
}

fn is_zero(value: &u32) -> bool {
    *value == 0
}

/// What is wrong with one node of a controller tree. [`ControllerError::Node`] pairs it with the
/// node's path.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum NodeProblem {
    /// The name is empty.
    #[error("name is empty")]
    EmptyName,
    /// The name contains the path separator.
    #[error("name contains '/', which separates names in node paths")]
    NameContainsSeparator,
    /// A sibling already has this name, so the two would share a path.
    #[error("name is already used by a sibling")]
    DuplicateName,
    /// The network declares no input group.
    #[error("declares no inputs")]
    NoInputs,
    /// The same input group is listed twice.
    #[error("input group '{group}' is listed more than once")]
    DuplicateInput { group: InputGroup },
    /// The network has no hidden neuron.
    #[error("hidden is 0, a network needs at least one hidden neuron")]
    NoHiddenNeurons,
    /// A primitive lists children.
    #[error("a primitive has no children, found {n_children}")]
    PrimitiveWithChildren { n_children: usize },
    /// An arbitrator has no children.
    #[error("an arbitrator needs at least one child")]
    ArbitratorWithoutChildren,
    /// A primitive asks to keep a child on: only arbitrators have children to keep.
    #[error("min_active_cycles is {min_active_cycles}, but only an arbitrator switches children")]
    MinActiveOnPrimitive { min_active_cycles: u32 },
    /// The stored genome has the wrong length.
    #[error("genome has {found} genes, topology {topology} needs {needed}")]
    GenomeLength {
        found: usize,
        needed: usize,
        topology: CtrnnTopology,
    },
    /// The free genome supplied at evaluation time has the wrong length.
    #[error("free genome has {found} genes, topology {topology} needs {needed}")]
    FreeGenomeLength {
        found: usize,
        needed: usize,
        topology: CtrnnTopology,
    },
    /// The node is free but no free genome was supplied.
    #[error(
        "is the free node (no genome) and needs {needed} genes for topology {topology}, but none were given"
    )]
    MissingFreeGenome {
        needed: usize,
        topology: CtrnnTopology,
    },
    /// A gene is NaN or infinite.
    #[error("gene {gene_idx} is not finite ({value})")]
    NonFiniteGene { gene_idx: usize, value: f32 },
    /// A gene lies outside [-10, 10].
    #[error("gene {gene_idx} is {value}, outside [-10, 10]")]
    GeneOutOfRange { gene_idx: usize, value: f32 },
    /// A second node without genome; only one node may be free.
    #[error(
        "has no genome, but {first_free_path} is already the free node and only one may be free"
    )]
    SecondFreeNode { first_free_path: String },
    /// The network could not be built (validation normally catches this first).
    #[error("network: {0}")]
    Network(CtrnnError),
}

// By hand rather than `#[from]`, which would also make the cause a `source()` that `{:#}`
// prints a second time after the message.
impl From<CtrnnError> for NodeProblem {
    fn from(error: CtrnnError) -> Self {
        NodeProblem::Network(error)
    }
}

/// Everything that can be wrong with a controller file or with building a controller from it.
#[derive(Debug, Error)]
pub enum ControllerError {
    /// The text is not JSON of the controller file shape (includes unknown fields).
    #[error("controller file does not parse: {0}")]
    Json(serde_json::Error),
    /// The schema string is not the one this code reads.
    #[error("schema is {found:?}, expected {expected:?}", expected = CONTROLLER_SCHEMA)]
    WrongSchema { found: String },
    /// One node is invalid; `path` names it from the root, e.g. `rescue/solve_maze/turn_left`.
    #[error("{path}: {problem}")]
    Node { path: String, problem: NodeProblem },
    /// A free genome was supplied but every node already has its genome.
    #[error("a free genome was given, but the controller has no free node")]
    NoFreeNode,
}

// By hand rather than `#[from]`: see `NodeProblem`'s.
impl From<serde_json::Error> for ControllerError {
    fn from(error: serde_json::Error) -> Self {
        ControllerError::Json(error)
    }
}

impl ControllerError {
    fn node(path: &str, problem: NodeProblem) -> Self {
        ControllerError::Node {
            path: path.to_owned(),
            problem,
        }
    }
}

impl NodeSpec {
    /// A free primitive (no genome yet) that reads `inputs` and drives the two wheels.
    pub fn primitive(name: impl Into<String>, inputs: Vec<InputGroup>, hidden: usize) -> NodeSpec {
        NodeSpec {
            name: name.into(),
            kind: NodeKind::Primitive,
            inputs,
            hidden,
            genome: None,
            children: Vec::new(),
            min_active_cycles: 0,
        }
    }

    /// A free arbitrator (no genome yet) over `children`, with the paper's activator: no
    /// minimum time per switch-on.
    pub fn arbitrator(
        name: impl Into<String>,
        inputs: Vec<InputGroup>,
        hidden: usize,
        children: Vec<NodeSpec>,
    ) -> NodeSpec {
        NodeSpec {
            name: name.into(),
            kind: NodeKind::Arbitrator,
            inputs,
            hidden,
            genome: None,
            children,
            min_active_cycles: 0,
        }
    }

    /// This node with its genes fixed to `genome`.
    pub fn with_genome(self, genome: Vec<f32>) -> NodeSpec {
        NodeSpec {
            genome: Some(genome),
            ..self
        }
    }

    /// Number of network inputs: the sum of the widths of the input groups.
    pub fn n_inputs(&self) -> usize {
        self.inputs.iter().map(|group| group.width()).sum()
    }

    /// Number of network outputs: two for a primitive, one per child for an arbitrator.
    pub fn n_outputs(&self) -> usize {
        match self.kind {
            NodeKind::Primitive => PRIMITIVE_OUTPUTS,
            NodeKind::Arbitrator => self.children.len(),
        }
    }

    /// The node's network shape.
    pub fn topology(&self) -> CtrnnTopology {
        CtrnnTopology::new(self.n_inputs(), self.hidden, self.n_outputs())
    }

    /// Whether this node is the free node (no stored genome).
    pub fn is_free(&self) -> bool {
        self.genome.is_none()
    }

    /// A stable 64-bit hash of this sub-tree, as 16 hex digits; see
    /// [`ControllerFile::content_hash`].
    pub fn content_hash(&self) -> String {
        let mut hasher = Fnv1a::new();
        hash_node_tree(&mut hasher, self);
        format!("{:016x}", hasher.finish())
    }
}

/// One node met in a pre-order walk: the node, its path, its parent's walk index and its depth.
struct WalkedNode<'a> {
    spec: &'a NodeSpec,
    path: String,
    parent_walk_idx: Option<usize>,
    depth: usize,
}

/// Lists the tree's nodes in pre-order (a node before its children, children in order) with
/// their paths. It uses an explicit stack so a deep tree cannot overflow the call stack.
fn walk_pre_order(root: &NodeSpec) -> Vec<WalkedNode<'_>> {
    let mut walked = Vec::new();
    let mut stack: Vec<(&NodeSpec, Option<usize>, usize)> = vec![(root, None, 0)];
    while let Some((spec, parent_walk_idx, depth)) = stack.pop() {
        let path = match parent_walk_idx {
            Some(parent) => format!(
                "{}{PATH_SEPARATOR}{}",
                walked_path(&walked, parent),
                spec.name
            ),
            None => spec.name.clone(),
        };
        let walk_idx = walked.len();
        walked.push(WalkedNode {
            spec,
            path,
            parent_walk_idx,
            depth,
        });
        // Pushed in reverse so the first child is popped, and so numbered, first.
        for child in spec.children.iter().rev() {
            stack.push((child, Some(walk_idx), depth + 1));
        }
    }
    walked
}

fn walked_path<'w>(walked: &'w [WalkedNode<'_>], walk_idx: usize) -> &'w str {
    walked.get(walk_idx).map_or("", |node| node.path.as_str())
}

/// Checks that a genome fits a topology and that every gene is finite and within [-10, 10].
fn check_genes(genes: &[f32], topology: CtrnnTopology, free: bool) -> Result<(), NodeProblem> {
    let needed = topology.n_genes();
    if genes.len() != needed {
        let found = genes.len();
        return Err(if free {
            NodeProblem::FreeGenomeLength {
                found,
                needed,
                topology,
            }
        } else {
            NodeProblem::GenomeLength {
                found,
                needed,
                topology,
            }
        });
    }
    for (gene_idx, &value) in genes.iter().enumerate() {
        if !value.is_finite() {
            return Err(NodeProblem::NonFiniteGene { gene_idx, value });
        }
        if !(GENE_MIN..=GENE_MAX).contains(&value) {
            return Err(NodeProblem::GeneOutOfRange { gene_idx, value });
        }
    }
    Ok(())
}

/// Checks everything about one node that does not involve other nodes.
fn check_node(spec: &NodeSpec) -> Result<(), NodeProblem> {
    if spec.name.is_empty() {
        return Err(NodeProblem::EmptyName);
    }
    if spec.name.contains(PATH_SEPARATOR) {
        return Err(NodeProblem::NameContainsSeparator);
    }
    if spec.inputs.is_empty() {
        return Err(NodeProblem::NoInputs);
    }
    for (group_idx, group) in spec.inputs.iter().enumerate() {
        if spec.inputs[..group_idx].contains(group) {
            return Err(NodeProblem::DuplicateInput { group: *group });
        }
    }
    if spec.hidden == 0 {
        return Err(NodeProblem::NoHiddenNeurons);
    }
    match spec.kind {
        NodeKind::Primitive if !spec.children.is_empty() => {
            return Err(NodeProblem::PrimitiveWithChildren {
                n_children: spec.children.len(),
            });
        }
        NodeKind::Arbitrator if spec.children.is_empty() => {
            return Err(NodeProblem::ArbitratorWithoutChildren);
        }
        NodeKind::Primitive if spec.min_active_cycles > 0 => {
            return Err(NodeProblem::MinActiveOnPrimitive {
                min_active_cycles: spec.min_active_cycles,
            });
        }
        _ => {}
    }
    if let Some(genes) = &spec.genome {
        check_genes(genes, spec.topology(), false)?;
    }
    Ok(())
}

impl ControllerFile {
    /// A file of the current schema around the given tree.
    pub fn new(root: NodeSpec) -> Self {
        Self {
            schema: CONTROLLER_SCHEMA.to_owned(),
            root,
        }
    }

    /// Parses and validates a controller file.
    pub fn from_json_str(text: &str) -> Result<Self, ControllerError> {
        let file: ControllerFile = serde_json::from_str(text)?;
        file.validate()?;
        Ok(file)
    }

    /// The file as indented JSON. Serialising these plain types does not fail in practice; the
    /// error is passed on rather than hidden.
    pub fn to_json_pretty(&self) -> Result<String, ControllerError> {
        Ok(serde_json::to_string_pretty(self)?)
    }

    /// Checks the schema and every node; the first problem found is returned with the path of
    /// the offending node. Nodes are checked in pre-order.
    pub fn validate(&self) -> Result<(), ControllerError> {
        if self.schema != CONTROLLER_SCHEMA {
            return Err(ControllerError::WrongSchema {
                found: self.schema.clone(),
            });
        }
        let walked = walk_pre_order(&self.root);
        // Paths, not names, identify nodes: the paper's solve_maze and return_room arbitrate
        // over the same three primitives, so one name appears under several parents. Two
        // nodes with the same path would be indistinguishable in traces and replays.
        let mut first_path: HashSet<&str> = HashSet::new();
        let mut first_free_path: Option<&str> = None;
        for node in &walked {
            check_node(node.spec).map_err(|problem| ControllerError::node(&node.path, problem))?;
            if !first_path.insert(&node.path) {
                let problem = NodeProblem::DuplicateName;
                return Err(ControllerError::node(&node.path, problem));
            }
            if node.spec.is_free() {
                if let Some(first_free_path) = first_free_path {
                    let problem = NodeProblem::SecondFreeNode {
                        first_free_path: first_free_path.to_owned(),
                    };
                    return Err(ControllerError::node(&node.path, problem));
                }
                first_free_path = Some(&node.path);
            }
        }
        Ok(())
    }

    /// The path and topology of the free node, if the tree has one (the first in pre-order if
    /// an unvalidated tree has several).
    pub fn free_node_topology(&self) -> Option<(String, CtrnnTopology)> {
        walk_pre_order(&self.root)
            .into_iter()
            .find(|node| node.spec.is_free())
            .map(|node| (node.path, node.spec.topology()))
    }

    /// A copy of this file with the free node's genome filled in: how an evolved controller is
    /// saved. The genes are checked like any stored genome.
    pub fn with_free_genome(&self, genes: &[f32]) -> Result<ControllerFile, ControllerError> {
        let (path, topology) = self
            .free_node_topology()
            .ok_or(ControllerError::NoFreeNode)?;
        check_genes(genes, topology, true)
            .map_err(|problem| ControllerError::node(&path, problem))?;
        let mut filled = self.clone();
        let mut stack: Vec<&mut NodeSpec> = vec![&mut filled.root];
        while let Some(node) = stack.pop() {
            if node.genome.is_none() {
                node.genome = Some(genes.to_vec());
                break;
            }
            // Reverse order keeps the search in pre-order, matching `free_node_topology`.
            stack.extend(node.children.iter_mut().rev());
        }
        Ok(filled)
    }

    /// A stable 64-bit content hash of the file as 16 hex digits, for caching fixed sub-trees.
    ///
    /// It is FNV-1a over a fixed binary encoding of the tree, not over JSON text, so it does not
    /// depend on how a JSON library formats floats and is the same on every platform and in
    /// every run. Numbers are 8 little-endian bytes (u64) and strings are their byte length as
    /// such a number followed by their UTF-8 bytes. The encoding is the schema string, then per
    /// node in pre-order: the name string; the kind as one byte (primitive 0, arbitrator 1);
    /// the number of input groups, then one byte per group, its place in the sensor registry
    /// (ir 0, light 1, near_robot 2, rab 3; a new sensor is appended, so these stay); the
    /// hidden count; the genome as byte 0 for the free node, or byte 1, the gene count and each
    /// gene's f32 bits as 4 little-endian bytes; the number of children; and, only when it is
    /// not 0, the 17 bytes `min_active_cycles` and its value. Two files hash alike exactly when
    /// they are equal field by field with bit-identical genes.
    pub fn content_hash(&self) -> String {
        let mut hasher = Fnv1a::new();
        hasher.write_str(&self.schema);
        hash_node_tree(&mut hasher, &self.root);
        format!("{:016x}", hasher.finish())
    }

    /// Every node's path (`rescue/solve_maze/turn_left`) in pre-order, the order of node
    /// indices in a [`Controller`] built from this file.
    pub fn node_paths(&self) -> Vec<String> {
        walk_pre_order(&self.root)
            .into_iter()
            .map(|node| node.path)
            .collect()
    }
}

/// Feeds a controller tree into a content hash, in pre-order.
fn hash_node_tree(hasher: &mut Fnv1a, root: &NodeSpec) {
    let mut stack = vec![root];
    while let Some(node) = stack.pop() {
        hasher.write_str(&node.name);
        hasher.write_bytes(&[match node.kind {
            NodeKind::Primitive => 0,
            NodeKind::Arbitrator => 1,
        }]);
        hasher.write_u64(node.inputs.len() as u64);
        for group in &node.inputs {
            hasher.write_bytes(&[group.index() as u8]);
        }
        hasher.write_u64(node.hidden as u64);
        match &node.genome {
            None => hasher.write_bytes(&[0]),
            Some(genes) => {
                hasher.write_bytes(&[1]);
                hasher.write_u64(genes.len() as u64);
                for gene in genes {
                    hasher.write_bytes(&gene.to_bits().to_le_bytes());
                }
            }
        }
        hasher.write_u64(node.children.len() as u64);
        // Written only when set, so every tree with the paper's activator keeps the hash
        // (and so the run fingerprints) it had before the option existed.
        if node.min_active_cycles > 0 {
            hasher.write_bytes(b"min_active_cycles");
            hasher.write_u64(u64::from(node.min_active_cycles));
        }
        stack.extend(node.children.iter().rev());
    }
}

/// The two wheel outputs of the active primitive, each in [0, 1]; the simulator maps them to
/// wheel speeds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WheelOutputs {
    /// Left wheel output.
    pub left: f32,
    /// Right wheel output.
    pub right: f32,
}

/// One node of the flattened tree.
#[derive(Debug, Clone)]
pub(crate) struct RuntimeNode {
    name: String,
    path: String,
    pub(crate) kind: NodeKind,
    pub(crate) inputs: Vec<InputGroup>,
    pub(crate) net: Ctrnn,
    /// Node indices of the children, in output order.
    pub(crate) children: Vec<usize>,
    /// One past the last node index of this node's sub-tree: in pre-order a sub-tree is the
    /// contiguous index range `own index .. subtree_end`.
    pub(crate) subtree_end: usize,
    /// Where this node's outputs start in `Controller::outputs`.
    output_offset: usize,
    /// Position (0-based, among this node's children) of the child activated in this node's
    /// last step since its last reset.
    active_child: Option<usize>,
    /// Arbitrators: the fewest cycles a child stays on once switched on (0: no minimum).
    pub(crate) min_active_cycles: u32,
    /// Arbitrators: consecutive steps the active child has been on, counting the last one.
    active_for: u32,
}

/// A runnable controller tree. Node index 0 is the root and indices follow pre-order.
///
/// One [`Controller::step`] runs the root, then the child its activator chose, and so on down to
/// a primitive, whose outputs drive the wheels. Inactive sub-trees do not step. When an
/// arbitrator switches from one child to another, the sub-tree of the child it leaves is reset
/// (network states and the active-child memory of every arbitrator in it).
#[derive(Debug, Clone)]
pub struct Controller {
    nodes: Vec<RuntimeNode>,
    /// The outputs of every node's last step since its last reset, zeros otherwise.
    outputs: Vec<f32>,
    /// Scratch for the current node's inputs, as long as the widest node needs.
    input_buffer: Vec<f32>,
    /// Node indices from the root to the primitive of the last step; its capacity is the tree
    /// depth, so filling it never allocates.
    active_path: Vec<usize>,
    free_node: Option<usize>,
}

impl Controller {
    /// Builds a controller from a validated copy of `file`. `free_genome` supplies the genes of
    /// the free node and must be given exactly when the file has one.
    pub fn new(
        file: &ControllerFile,
        free_genome: Option<&[f32]>,
    ) -> Result<Self, ControllerError> {
        file.validate()?;
        let walked = walk_pre_order(&file.root);

        let free_walk_idx = walked.iter().position(|node| node.spec.is_free());
        match (free_walk_idx, free_genome) {
            (None, Some(_)) => return Err(ControllerError::NoFreeNode),
            (Some(walk_idx), None) => {
                let node = &walked[walk_idx];
                let topology = node.spec.topology();
                let problem = NodeProblem::MissingFreeGenome {
                    needed: topology.n_genes(),
                    topology,
                };
                return Err(ControllerError::node(&node.path, problem));
            }
            (Some(walk_idx), Some(genes)) => {
                let node = &walked[walk_idx];
                check_genes(genes, node.spec.topology(), true)
                    .map_err(|problem| ControllerError::node(&node.path, problem))?;
            }
            (None, None) => {}
        }

        let mut nodes: Vec<RuntimeNode> = Vec::with_capacity(walked.len());
        let mut output_offset = 0;
        let mut max_inputs = 0;
        let mut max_depth = 0;
        for node in &walked {
            let spec = node.spec;
            let topology = spec.topology();
            let genes = match (&spec.genome, free_genome) {
                (Some(genes), _) => genes.as_slice(),
                (None, Some(genes)) => genes,
                // Unreachable after the free-genome check above; an empty genome would fail
                // the length check with a clear error anyway.
                (None, None) => &[],
            };
            let net = Ctrnn::new(topology, genes)
                .map_err(|err| ControllerError::node(&node.path, NodeProblem::Network(err)))?;
            // Walk indices are node indices: both are pre-order positions.
            let node_idx = nodes.len();
            if let Some(parent) = node.parent_walk_idx.and_then(|idx| nodes.get_mut(idx)) {
                parent.children.push(node_idx);
            }
            nodes.push(RuntimeNode {
                name: spec.name.clone(),
                path: node.path.clone(),
                kind: spec.kind,
                inputs: spec.inputs.clone(),
                net,
                children: Vec::with_capacity(spec.children.len()),
                subtree_end: 0,
                output_offset,
                active_child: None,
                min_active_cycles: spec.min_active_cycles,
                active_for: 0,
            });
            output_offset += topology.n_outputs;
            max_inputs = max_inputs.max(topology.n_inputs);
            max_depth = max_depth.max(node.depth);
        }
        // In pre-order a node's sub-tree ends where its last child's sub-tree ends, so one
        // backward pass fills every `subtree_end`.
        for node_idx in (0..nodes.len()).rev() {
            let end = match nodes[node_idx].children.last() {
                Some(&last_child) => nodes[last_child].subtree_end,
                None => node_idx + 1,
            };
            nodes[node_idx].subtree_end = end;
        }

        Ok(Self {
            nodes,
            outputs: vec![0.0; output_offset],
            input_buffer: vec![0.0; max_inputs],
            active_path: Vec::with_capacity(max_depth + 1),
            free_node: free_walk_idx,
        })
    }

    /// Resets every network and every activator, as at the start of a sample.
    pub fn reset(&mut self) {
        self.reset_range(0, self.nodes.len());
        self.active_path.clear();
    }

    /// Resets the nodes with indices in `start..end`: a whole sub-tree when the range comes from
    /// `subtree_end`.
    fn reset_range(&mut self, start: usize, end: usize) {
        for node in self.nodes.get_mut(start..end).unwrap_or_default() {
            node.net.reset();
            node.active_child = None;
            node.active_for = 0;
            let n_outputs = node.net.topology().n_outputs;
            if let Some(outputs) = self
                .outputs
                .get_mut(node.output_offset..node.output_offset + n_outputs)
            {
                outputs.fill(0.0);
            }
        }
    }

    /// Runs one control cycle of `dt` seconds on `frame` and returns the active primitive's wheel
    /// outputs. `dt` must be positive and finite; otherwise the outputs are meaningless (NaN),
    /// though nothing panics. Never allocates.
    pub fn step(&mut self, frame: &SensorFrame, dt: f32) -> WheelOutputs {
        self.active_path.clear();
        let mut node_idx = 0;
        // Each descent goes to a child, whose pre-order index is larger, and every arbitrator has
        // a child, so the walk reaches a primitive within `n_nodes` iterations.
        for _ in 0..self.nodes.len() {
            self.active_path.push(node_idx);
            let Some(node) = self.nodes.get_mut(node_idx) else {
                break;
            };

            let mut n_filled = 0;
            for group in &node.inputs {
                let values = frame.values(*group);
                let slots = self.input_buffer.get_mut(n_filled..).unwrap_or_default();
                for (slot, &value) in slots.iter_mut().zip(values) {
                    *slot = value;
                }
                n_filled += values.len();
            }
            let inputs = self.input_buffer.get(..n_filled).unwrap_or_default();
            let n_outputs = node.net.topology().n_outputs;
            let outputs = self
                .outputs
                .get_mut(node.output_offset..node.output_offset + n_outputs)
                .unwrap_or_default();
            node.net.step_prechecked(inputs, dt, outputs);

            match node.kind {
                NodeKind::Primitive => {
                    return match *outputs {
                        [left, right] => WheelOutputs { left, right },
                        _ => WheelOutputs::default(),
                    };
                }
                NodeKind::Arbitrator => {
                    let (chosen, left) = arbitrate(
                        outputs,
                        &mut node.active_child,
                        &mut node.active_for,
                        node.min_active_cycles,
                    );
                    let Some(&chosen_node) = node.children.get(chosen) else {
                        break;
                    };
                    if let Some(previous) = left
                        && let Some(&left_node) = node.children.get(previous)
                    {
                        let end = self
                            .nodes
                            .get(left_node)
                            .map_or(left_node, |n| n.subtree_end);
                        self.reset_range(left_node, end);
                    }
                    node_idx = chosen_node;
                }
            }
        }
        WheelOutputs::default()
    }

    /// Node indices from the root to the primitive that drove the wheels in the last step; empty
    /// before the first step and after a reset.
    pub fn active_path(&self) -> &[usize] {
        &self.active_path
    }

    /// The child position the root arbitrator chose in the last step, `None` if the root is a
    /// primitive or nothing has stepped since the last reset.
    pub fn root_choice(&self) -> Option<usize> {
        self.nodes.first().and_then(|root| root.active_child)
    }

    /// The position among the root's children of the child named `name`, `None` if the root
    /// is a primitive or has no such child.
    pub fn root_child_index(&self, name: &str) -> Option<usize> {
        let root = self.nodes.first()?;
        root.children
            .iter()
            .position(|&child| self.nodes.get(child).is_some_and(|node| node.name == name))
    }

    /// The child position node `node_idx` activated in its last step since its last reset.
    pub fn active_child(&self, node_idx: usize) -> Option<usize> {
        self.nodes.get(node_idx).and_then(|node| node.active_child)
    }

    /// The nodes in pre-order, for the lockstep controller built from this one.
    pub(crate) fn nodes(&self) -> &[RuntimeNode] {
        &self.nodes
    }

    /// Number of nodes in the tree.
    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Node names by node index (pre-order).
    pub fn node_names(&self) -> Vec<String> {
        self.nodes.iter().map(|node| node.name.clone()).collect()
    }

    /// The name of node `node_idx`.
    pub fn node_name(&self, node_idx: usize) -> Option<&str> {
        self.nodes.get(node_idx).map(|node| node.name.as_str())
    }

    /// The path of node `node_idx` from the root, e.g. `rescue/solve_maze/turn_left`.
    pub fn node_path(&self, node_idx: usize) -> Option<&str> {
        self.nodes.get(node_idx).map(|node| node.path.as_str())
    }

    /// The index of the node at `path`, e.g. `rescue/return_room/follow_wall`.
    pub fn node_index(&self, path: &str) -> Option<usize> {
        self.nodes.iter().position(|node| node.path == path)
    }

    /// Whether node `node_idx` is a primitive or an arbitrator.
    pub fn node_kind(&self, node_idx: usize) -> Option<NodeKind> {
        self.nodes.get(node_idx).map(|node| node.kind)
    }

    /// The node indices of the children of node `node_idx`, in output order.
    pub fn node_children(&self, node_idx: usize) -> Option<&[usize]> {
        self.nodes
            .get(node_idx)
            .map(|node| node.children.as_slice())
    }

    /// The network of node `node_idx`, for inspecting its state.
    pub fn node_network(&self, node_idx: usize) -> Option<&Ctrnn> {
        self.nodes.get(node_idx).map(|node| &node.net)
    }

    /// The index of the node whose genes were supplied as the free genome, if any.
    pub fn free_node(&self) -> Option<usize> {
        self.free_node
    }

    /// The outputs of node `node_idx` from its last step since its last reset (zeros if it has
    /// not stepped since), for traces.
    pub fn last_outputs(&self, node_idx: usize) -> Option<&[f32]> {
        let node = self.nodes.get(node_idx)?;
        let n_outputs = node.net.topology().n_outputs;
        self.outputs
            .get(node.output_offset..node.output_offset + n_outputs)
    }
}

/// An arbitrator's choice in one step, from its outputs and its memory of the child it chose
/// last (`active_child`, on for `active_for` steps): the argmax, unless the active child has
/// been on for fewer than `min_active_cycles` steps. Updates the memory and returns the chosen
/// child's position and, when it switched, the position of the child it left (whose sub-tree
/// the caller resets). The scalar controller and the lockstep one both decide here.
#[inline]
pub(crate) fn arbitrate(
    outputs: &[f32],
    active_child: &mut Option<usize>,
    active_for: &mut u32,
    min_active_cycles: u32,
) -> (usize, Option<usize>) {
    let mut chosen = argmax(outputs);
    // A child switched on fewer than `min_active_cycles` steps ago stays on.
    if let Some(active) = *active_child
        && *active_for < min_active_cycles
    {
        chosen = active;
    }
    let previous = active_child.replace(chosen);
    *active_for = if previous == Some(chosen) {
        active_for.saturating_add(1)
    } else {
        1
    };
    (chosen, previous.filter(|&previous| previous != chosen))
}

/// Index of the largest value, the lowest index on ties. NaN never wins a comparison, so NaN
/// outputs fall back to the lowest index instead of panicking.
#[inline]
fn argmax(values: &[f32]) -> usize {
    let mut best_idx = 0;
    let mut best_value = f32::NEG_INFINITY;
    for (idx, &value) in values.iter().enumerate() {
        if value > best_value {
            best_idx = idx;
            best_value = value;
        }
    }
    best_idx
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::mix64;

    /// Deterministic pseudo-random genes in [-10, 10] for `topology`.
    fn random_genes(topology: CtrnnTopology, seed: u64) -> Vec<f32> {
        (0..topology.n_genes() as u64)
            .map(|gene_idx| {
                let bits = mix64(seed ^ mix64(gene_idx));
                (bits >> 40) as f32 / (1u64 << 24) as f32 * 20.0 - 10.0
            })
            .collect()
    }

    fn primitive(name: &str, inputs: &[InputGroup], hidden: usize, seed: u64) -> NodeSpec {
        let spec = NodeSpec::primitive(name, inputs.to_vec(), hidden);
        let genes = random_genes(spec.topology(), seed);
        spec.with_genome(genes)
    }

    fn arbitrator(
        name: &str,
        inputs: &[InputGroup],
        hidden: usize,
        seed: u64,
        children: Vec<NodeSpec>,
    ) -> NodeSpec {
        let spec = NodeSpec::arbitrator(name, inputs.to_vec(), hidden, children);
        let genes = random_genes(spec.topology(), seed);
        spec.with_genome(genes)
    }

    /// The rescue tree of the paper, with random genes and `solve_maze` free.
    fn rescue_tree() -> ControllerFile {
        const IR: InputGroup = InputGroup::IR;
        const LIGHT: InputGroup = InputGroup::LIGHT;
        const NEAR_ROBOT: InputGroup = InputGroup::NEAR_ROBOT;
        let maze_children = |suffix: &str, seed: u64| {
            vec![
                primitive(&format!("follow_wall{suffix}"), &[IR], 3, seed),
                primitive(&format!("turn_left{suffix}"), &[IR], 3, seed + 1),
                primitive(&format!("turn_right{suffix}"), &[IR], 3, seed + 2),
            ]
        };
        let mut solve_maze = arbitrator("solve_maze", &[IR, LIGHT], 10, 10, maze_children("", 20));
        solve_maze.genome = None;
        ControllerFile::new(arbitrator(
            "rescue",
            &[IR, NEAR_ROBOT],
            10,
            1,
            vec![
                primitive("exit_room", &[IR], 10, 2),
                solve_maze,
                arbitrator("return_to_room", &[IR], 10, 3, maze_children("", 30)),
            ],
        ))
    }

    fn frame(ir: [f32; 4], light: [f32; 2], near_robot: f32) -> SensorFrame {
        SensorFrame::default()
            .with(InputGroup::IR, &ir)
            .with(InputGroup::LIGHT, &light)
            .with(InputGroup::NEAR_ROBOT, &[near_robot])
    }

    #[test]
    fn json_round_trips_bit_exactly() {
        let file = rescue_tree();
        let text = file.to_json_pretty().unwrap();
        let parsed = ControllerFile::from_json_str(&text).unwrap();
        assert_eq!(parsed, file);
        let original_bits: Vec<u32> = walk_pre_order(&file.root)
            .iter()
            .flat_map(|node| node.spec.genome.iter().flatten().map(|g| g.to_bits()))
            .collect();
        let parsed_bits: Vec<u32> = walk_pre_order(&parsed.root)
            .iter()
            .flat_map(|node| node.spec.genome.iter().flatten().map(|g| g.to_bits()))
            .collect();
        assert_eq!(original_bits, parsed_bits);
        assert!(text.contains("\"schema\": \"hevo.controller/1\""));
        assert!(text.contains("\"kind\": \"arbitrator\""));
        assert!(text.contains("\"near_robot\""));
    }

    #[test]
    fn parses_the_documented_shape_and_rejects_unknown_fields() {
        let genes = vec!["0.5"; 35].join(", ");
        let text = format!(
            r#"{{ "schema": "hevo.controller/1",
                 "root": {{ "name": "solve_maze", "kind": "arbitrator", "inputs": ["ir", "light"],
                           "hidden": 10,
                           "children": [ {{ "name": "follow_wall", "kind": "primitive",
                                           "inputs": ["ir"], "hidden": 3, "genome": [{genes}] }} ] }} }}"#
        );
        let file = ControllerFile::from_json_str(&text).unwrap();
        let (path, topology) = file.free_node_topology().unwrap();
        assert_eq!(path, "solve_maze");
        assert_eq!(topology, CtrnnTopology::new(6, 10, 1));

        let with_extra = text.replacen("\"hidden\": 3", "\"hidden\": 3, \"tau\": 1", 1);
        let err = ControllerFile::from_json_str(&with_extra).unwrap_err();
        assert!(matches!(err, ControllerError::Json(_)));
        assert!(err.to_string().contains("unknown field `tau`"), "{err}");
    }

    #[test]
    fn validation_errors_name_the_node_path() {
        let mut file = rescue_tree();
        file.root.children[1].children[1]
            .genome
            .as_mut()
            .unwrap()
            .pop();
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "rescue/solve_maze/turn_left: genome has 34 genes, topology 4-3-2 needs 35"
        );

        let mut file = rescue_tree();
        file.root.children[2].children[2].genome.as_mut().unwrap()[7] = 10.5;
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "rescue/return_to_room/turn_right: gene 7 is 10.5, outside [-10, 10]"
        );

        let mut file = rescue_tree();
        file.root.children[0].genome.as_mut().unwrap()[3] = f32::INFINITY;
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "rescue/exit_room: gene 3 is not finite (inf)"
        );

        // The same name under two parents is the paper's tree (rescue_tree has it); the same
        // name twice among siblings would make two nodes share a path.
        let mut file = rescue_tree();
        file.root.children[2].children[0].name = "turn_left".to_owned();
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "rescue/return_to_room/turn_left: name is already used by a sibling"
        );

        let mut file = rescue_tree();
        file.root.children[0].genome = None;
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "rescue/solve_maze: has no genome, but rescue/exit_room is already the free node and \
             only one may be free"
        );

        let mut file = rescue_tree();
        file.root.children[0]
            .children
            .push(primitive("stray", &[InputGroup::IR], 1, 5));
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "rescue/exit_room: a primitive has no children, found 1"
        );

        let mut file = rescue_tree();
        file.root.children[2].kind = NodeKind::Arbitrator;
        file.root.children[2].children.clear();
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "rescue/return_to_room: an arbitrator needs at least one child"
        );

        let mut file = rescue_tree();
        file.root.children[1].children[0].hidden = 0;
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "rescue/solve_maze/follow_wall: hidden is 0, a network needs at least one hidden neuron"
        );

        let mut file = rescue_tree();
        file.root.children[0].inputs.push(InputGroup::IR);
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "rescue/exit_room: input group 'ir' is listed more than once"
        );

        let mut file = rescue_tree();
        file.root.children[0].inputs.clear();
        assert!(
            file.validate()
                .unwrap_err()
                .to_string()
                .starts_with("rescue/exit_room: ")
        );

        let mut file = rescue_tree();
        file.root.children[0].name = "exit/room".to_owned();
        assert!(matches!(
            file.validate(),
            Err(ControllerError::Node {
                problem: NodeProblem::NameContainsSeparator,
                ..
            })
        ));

        let mut file = rescue_tree();
        file.schema = "hevo.controller/2".to_owned();
        assert_eq!(
            file.validate().unwrap_err().to_string(),
            "schema is \"hevo.controller/2\", expected \"hevo.controller/1\""
        );
    }

    #[test]
    fn huge_hidden_count_is_an_error_not_a_panic() {
        let mut file = rescue_tree();
        file.root.children[0].hidden = usize::MAX;
        let err = file.validate().unwrap_err().to_string();
        assert!(
            err.starts_with("rescue/exit_room: genome has 182 genes"),
            "{err}"
        );
    }

    #[test]
    fn free_genome_handling() {
        let file = rescue_tree();
        let (path, topology) = file.free_node_topology().unwrap();
        assert_eq!(path, "rescue/solve_maze");
        assert_eq!(topology, CtrnnTopology::new(6, 10, 3));
        assert_eq!(topology.n_genes(), 213);

        let err = Controller::new(&file, None).unwrap_err();
        assert_eq!(
            err.to_string(),
            "rescue/solve_maze: is the free node (no genome) and needs 213 genes for topology \
             6-10-3, but none were given"
        );
        let err = Controller::new(&file, Some(&[0.0; 212])).unwrap_err();
        assert_eq!(
            err.to_string(),
            "rescue/solve_maze: free genome has 212 genes, topology 6-10-3 needs 213"
        );
        let mut genes = random_genes(topology, 99);
        genes[5] = f32::NAN;
        assert!(matches!(
            Controller::new(&file, Some(&genes)),
            Err(ControllerError::Node {
                problem: NodeProblem::NonFiniteGene { gene_idx: 5, .. },
                ..
            })
        ));

        let genes = random_genes(topology, 99);
        let controller = Controller::new(&file, Some(&genes)).unwrap();
        assert_eq!(
            controller.free_node(),
            controller.node_index("rescue/solve_maze")
        );

        let filled = file.with_free_genome(&genes).unwrap();
        assert!(filled.free_node_topology().is_none());
        filled.validate().unwrap();
        assert!(matches!(
            Controller::new(&filled, Some(&genes)),
            Err(ControllerError::NoFreeNode)
        ));
        assert!(matches!(
            filled.with_free_genome(&genes),
            Err(ControllerError::NoFreeNode)
        ));
        assert!(file.with_free_genome(&genes[1..]).is_err());

        // Evaluating with the free genome and loading the saved file behave identically.
        let mut from_free = Controller::new(&file, Some(&genes)).unwrap();
        let mut from_saved = Controller::new(&filled, None).unwrap();
        for cycle in 0..300u32 {
            let t = cycle as f32 * 0.1;
            let sensors = frame(
                [t.sin().abs(), 0.2, (t * 0.3).cos().abs(), 0.0],
                [(cycle % 40 < 15) as u8 as f32, 0.0],
                (cycle > 150) as u8 as f32,
            );
            assert_eq!(
                from_free.step(&sensors, 0.1),
                from_saved.step(&sensors, 0.1)
            );
            assert_eq!(from_free.active_path(), from_saved.active_path());
        }
    }

    /// The documented encoding of [`ControllerFile::content_hash`], fed by hand, byte by byte,
    /// into FNV-1a (whose bytes are pinned by the published test vectors in `hash.rs`): the
    /// hash must never change, or caches keyed by it across versions and machines would
    /// silently miss.
    #[test]
    fn content_hash_is_fnv1a_of_the_documented_encoding() {
        fn number(bytes: &mut Vec<u8>, value: u64) {
            bytes.extend_from_slice(&value.to_le_bytes());
        }
        fn string(bytes: &mut Vec<u8>, text: &str) {
            number(bytes, text.len() as u64);
            bytes.extend_from_slice(text.as_bytes());
        }
        fn hash_of(bytes: &[u8]) -> String {
            let mut hasher = Fnv1a::new();
            hasher.write_bytes(bytes);
            format!("{:016x}", hasher.finish())
        }

        // A 1-1-2 primitive reading near_robot: 1 + 1 + 1 + 1 + 2 + 2 = 8 genes.
        let genes = [0.5f32, -1.0, 0.0, -0.0, 10.0, -10.0, 3.25, 1e-3];
        let tiny = ControllerFile::new(
            NodeSpec::primitive("p", vec![InputGroup::NEAR_ROBOT], 1).with_genome(genes.to_vec()),
        );
        let mut bytes = Vec::new();
        string(&mut bytes, "hevo.controller/1");
        string(&mut bytes, "p");
        bytes.push(0); // primitive
        number(&mut bytes, 1);
        bytes.push(2); // near_robot
        number(&mut bytes, 1); // hidden
        bytes.push(1); // a genome follows
        number(&mut bytes, 8);
        for gene in genes {
            bytes.extend_from_slice(&gene.to_bits().to_le_bytes());
        }
        number(&mut bytes, 0); // no children
        assert_eq!(tiny.content_hash(), hash_of(&bytes));
        // A node's own hash leaves the schema out.
        assert_eq!(tiny.root.content_hash(), hash_of(&bytes[8 + 17..]));
        // The same node reading the range-and-bearing board instead: group byte 3, and a
        // 5-1-2 network of 5 + 1 + 1 + 1 + 2 + 2 = 12 genes.
        let genes = [0.25f32; 12];
        let board = ControllerFile::new(
            NodeSpec::primitive("p", vec![InputGroup::RAB], 1).with_genome(genes.to_vec()),
        );
        let mut bytes = Vec::new();
        string(&mut bytes, "hevo.controller/1");
        string(&mut bytes, "p");
        bytes.push(0); // primitive
        number(&mut bytes, 1);
        bytes.push(3); // rab
        number(&mut bytes, 1); // hidden
        bytes.push(1); // a genome follows
        number(&mut bytes, 12);
        for gene in genes {
            bytes.extend_from_slice(&gene.to_bits().to_le_bytes());
        }
        number(&mut bytes, 0); // no children
        assert_eq!(board.content_hash(), hash_of(&bytes));

        // A free arbitrator that keeps a child on for 5 cycles, over two fixed 4-1-2
        // primitives (4 + 1 + 1 + 1 + 2 + 2 = 11 genes each), children in pre-order.
        let child = |name: &str, gene: f32| {
            NodeSpec::primitive(name, vec![InputGroup::IR], 1).with_genome(vec![gene; 11])
        };
        let mut root = NodeSpec::arbitrator(
            "a",
            vec![InputGroup::LIGHT, InputGroup::IR],
            2,
            vec![child("x", 1.0), child("yz", -2.0)],
        );
        root.min_active_cycles = 5;
        let tree = ControllerFile::new(root);
        let mut bytes = Vec::new();
        string(&mut bytes, "hevo.controller/1");
        string(&mut bytes, "a");
        bytes.push(1); // arbitrator
        number(&mut bytes, 2);
        bytes.extend_from_slice(&[1, 0]); // light, ir
        number(&mut bytes, 2); // hidden
        bytes.push(0); // free
        number(&mut bytes, 2); // children
        bytes.extend_from_slice(b"min_active_cycles");
        number(&mut bytes, 5);
        for (name, gene) in [("x", 1.0f32), ("yz", -2.0)] {
            string(&mut bytes, name);
            bytes.push(0);
            number(&mut bytes, 1);
            bytes.push(0); // ir
            number(&mut bytes, 1);
            bytes.push(1);
            number(&mut bytes, 11);
            for _ in 0..11 {
                bytes.extend_from_slice(&gene.to_bits().to_le_bytes());
            }
            number(&mut bytes, 0);
        }
        assert_eq!(tree.content_hash(), hash_of(&bytes));
    }

    #[test]
    fn equal_trees_hash_alike_and_any_one_change_changes_the_hash() {
        let file = rescue_tree();
        let hash = file.content_hash();
        // Equal trees built apart (built again, and read back from JSON) hash alike.
        assert_eq!(rescue_tree().content_hash(), hash);
        let parsed = ControllerFile::from_json_str(&file.to_json_pretty().unwrap()).unwrap();
        assert_eq!(parsed, file);
        assert_eq!(parsed.content_hash(), hash);

        // Each single change of one field, anywhere in the tree, gives a hash of its own.
        type Change = (&'static str, fn(&mut ControllerFile));
        let changes: &[Change] = &[
            ("schema", |f| f.schema.push('x')),
            ("root name", |f| f.root.name = "rescuer".into()),
            ("leaf name", |f| {
                f.root.children[2].children[0].name = "follow".into()
            }),
            ("kind", |f| f.root.children[0].kind = NodeKind::Arbitrator),
            ("an input group more", |f| {
                f.root.children[0].inputs.push(InputGroup::LIGHT)
            }),
            ("an input group other", |f| {
                f.root.children[0].inputs[0] = InputGroup::LIGHT
            }),
            ("input groups reordered", |f| f.root.inputs.reverse()),
            ("hidden", |f| f.root.children[0].hidden += 1),
            ("a gene", |f| {
                f.root.children[1].children[0].genome.as_mut().unwrap()[0] += 0.001
            }),
            ("the last gene", |f| {
                let genome = f.root.children[0].genome.as_mut().unwrap();
                *genome.last_mut().unwrap() += 0.001;
            }),
            ("a genome freed", |f| f.root.children[0].genome = None),
            ("the free node given genes", |f| {
                f.root.children[1].genome = Some(vec![0.0; 213])
            }),
            ("a gene less", |f| {
                f.root.children[0].genome.as_mut().unwrap().pop();
            }),
            ("children reordered", |f| f.root.children.swap(0, 2)),
            ("a child less", |f| {
                f.root.children[2].children.pop();
            }),
            ("min_active_cycles set", |f| {
                f.root.children[1].min_active_cycles = 5
            }),
            ("min_active_cycles on the root", |f| {
                f.root.min_active_cycles = 5
            }),
        ];
        let mut seen = std::collections::BTreeMap::from([(hash.clone(), "unchanged")]);
        for &(what, change) in changes {
            let mut changed = file.clone();
            change(&mut changed);
            assert_ne!(changed, file, "{what} changes nothing");
            let changed_hash = changed.content_hash();
            if let Some(other) = seen.insert(changed_hash, what) {
                panic!("{what} hashes like {other}");
            }
        }
        // The same gene as -0.0 and 0.0 are equal floats but different bits: the hash tells
        // them apart, as documented (bit-identical genes).
        let mut zero = file.clone();
        zero.root.children[0].genome.as_mut().unwrap()[0] = 0.0;
        let mut minus_zero = file.clone();
        minus_zero.root.children[0].genome.as_mut().unwrap()[0] = -0.0;
        assert_eq!(zero, minus_zero);
        assert_ne!(zero.content_hash(), minus_zero.content_hash());

        // The activator's minimum survives the file; left at 0 it is not written.
        let mut held = file.clone();
        held.root.children[1].min_active_cycles = 5;
        let held_json = held.to_json_pretty().unwrap();
        assert_eq!(held_json.matches("min_active_cycles").count(), 1);
        assert_eq!(ControllerFile::from_json_str(&held_json).unwrap(), held);
        assert!(!file.to_json_pretty().unwrap().contains("min_active_cycles"));
    }

    /// An arbitrator over `n_children` children reading `light` with hidden neurons that copy the
    /// inputs (tau 0.1 s, so with dt 0.1 s the state equals the net input), whose output `o` is
    /// sigma(10 f_o - 5) for o < 2 and a constant sigma(`other_bias`) for the rest.
    fn light_switch_genes(n_children: usize, other_bias: f32) -> Vec<f32> {
        let topology = CtrnnTopology::new(2, 2, n_children);
        let layout = topology.layout();
        let mut genes = vec![0.0; topology.n_genes()];
        // h0 <- light0 and h1 <- light1 with weight 10, theta -5: f_h = sigma(10 light - 5).
        genes[layout.input_weights.start] = 10.0;
        genes[layout.input_weights.start + 3] = 10.0;
        genes[layout.hidden_biases.clone()].fill(-5.0);
        genes[layout.tau_genes.clone()].fill(-10.0);
        for output_idx in 0..n_children {
            let row = layout.output_weights.start + output_idx * 2;
            if output_idx < 2 {
                genes[row + output_idx] = 10.0;
                genes[layout.output_biases.start + output_idx] = -5.0;
            } else {
                genes[layout.output_biases.start + output_idx] = other_bias;
            }
        }
        genes
    }

    /// A primitive with one slow hidden neuron (tau 31.6 s) that integrates IR 0, so its outputs
    /// depend on how long it has been active: left = sigma(10 f - 5), right = sigma(-10 f + 5).
    fn integrator(name: &str) -> NodeSpec {
        let topology = CtrnnTopology::new(4, 1, 2);
        let layout = topology.layout();
        let mut genes = vec![0.0; topology.n_genes()];
        genes[layout.input_weights.start] = 10.0;
        genes[layout.tau_genes.start] = 10.0;
        genes[layout.output_weights.start] = 10.0;
        genes[layout.output_weights.start + 1] = -10.0;
        genes[layout.output_biases.start] = -5.0;
        genes[layout.output_biases.start + 1] = 5.0;
        NodeSpec::primitive(name, vec![InputGroup::IR], 1).with_genome(genes)
    }

    fn switch_tree(n_children: usize, other_bias: f32) -> ControllerFile {
        let children = (0..n_children)
            .map(|idx| integrator(&format!("child{idx}")))
            .collect();
        ControllerFile::new(
            NodeSpec::arbitrator("switch", vec![InputGroup::LIGHT], 2, children)
                .with_genome(light_switch_genes(n_children, other_bias)),
        )
    }

    #[test]
    fn argmax_activator_picks_the_highest_output_and_ties_go_low() {
        assert_eq!(argmax(&[0.1, 0.7, 0.3]), 1);
        assert_eq!(argmax(&[0.5, 0.5, 0.5]), 0);
        assert_eq!(argmax(&[0.2, 0.9, 0.9]), 1);
        assert_eq!(argmax(&[f32::NAN, 0.1]), 1);
        assert_eq!(argmax(&[f32::NAN, f32::NAN]), 0);

        let ir = [1.0, 0.0, 0.0, 0.0];
        let mut controller = Controller::new(&switch_tree(3, -10.0), None).unwrap();
        controller.step(&frame(ir, [1.0, 0.0], 0.0), 0.1);
        assert_eq!(controller.root_choice(), Some(0));
        assert_eq!(controller.active_path(), &[0, 1]);
        controller.step(&frame(ir, [0.0, 1.0], 0.0), 0.1);
        assert_eq!(controller.root_choice(), Some(1));
        assert_eq!(controller.active_path(), &[0, 2]);
        // Both lights equal: outputs 0 and 1 are bit-identical, so the tie goes to child 0.
        controller.step(&frame(ir, [1.0, 1.0], 0.0), 0.1);
        let root_outputs = controller.last_outputs(0).unwrap();
        assert_eq!(root_outputs[0], root_outputs[1]);
        assert_eq!(controller.root_choice(), Some(0));
        controller.step(&frame(ir, [0.0, 0.0], 0.0), 0.1);
        assert_eq!(controller.root_choice(), Some(0));

        // A third output with a constant high bias wins whatever the lights say.
        let mut controller = Controller::new(&switch_tree(3, 10.0), None).unwrap();
        controller.step(&frame(ir, [1.0, 0.0], 0.0), 0.1);
        assert_eq!(controller.root_choice(), Some(2));
        assert_eq!(controller.active_path(), &[0, 3]);
    }

    #[test]
    fn a_minimum_keeps_a_switched_on_child_on() {
        let ir = [1.0, 0.0, 0.0, 0.0];
        let to_child0 = frame(ir, [1.0, 0.0], 0.0);
        let to_child1 = frame(ir, [0.0, 1.0], 0.0);
        let mut file = switch_tree(2, -10.0);
        file.root.min_active_cycles = 3;
        let mut controller = Controller::new(&file, None).unwrap();
        let mut choices = Vec::new();
        // Child 0 on, then asked for child 1 at once: it gets it after child 0's three cycles;
        // asked back for child 0 at once, it waits for child 1's three.
        for sensors in [&to_child0, &to_child1, &to_child1, &to_child1, &to_child0]
            .into_iter()
            .chain([&to_child0; 3])
        {
            controller.step(sensors, 0.1);
            choices.push(controller.root_choice().unwrap());
        }
        assert_eq!(choices, [0, 0, 0, 1, 1, 1, 0, 0]);
        // A reset forgets the count: the first choice after it is free.
        controller.reset();
        controller.step(&to_child1, 0.1);
        assert_eq!(controller.root_choice(), Some(1));
        // The paper's activator (0) switches in the very next cycle.
        file.root.min_active_cycles = 0;
        let mut free = Controller::new(&file, None).unwrap();
        free.step(&to_child0, 0.1);
        free.step(&to_child1, 0.1);
        assert_eq!(free.root_choice(), Some(1));

        // Only arbitrators have children to keep on.
        let mut primitive_file = switch_tree(2, -10.0);
        primitive_file.root.children[1].min_active_cycles = 2;
        let err = Controller::new(&primitive_file, None).unwrap_err();
        assert_eq!(
            err.to_string(),
            "switch/child1: min_active_cycles is 2, but only an arbitrator switches children"
        );
    }

    #[test]
    fn leaving_a_child_resets_it() {
        let ir = [1.0, 0.0, 0.0, 0.0];
        let to_child0 = frame(ir, [1.0, 0.0], 0.0);
        let to_child1 = frame(ir, [0.0, 1.0], 0.0);
        let file = switch_tree(2, 0.0);

        let mut fresh = Controller::new(&file, None).unwrap();
        let first_output = fresh.step(&to_child0, 0.1);

        let mut controller = Controller::new(&file, None).unwrap();
        let mut output = WheelOutputs::default();
        for _ in 0..10 {
            output = controller.step(&to_child0, 0.1);
        }
        // The integrator's outputs depend on its history, so without a reset they would differ.
        assert!(
            output.left > first_output.left + 0.1,
            "{output:?} vs {first_output:?}"
        );
        assert!(controller.node_network(1).unwrap().state()[0] > 0.0);

        for _ in 0..3 {
            controller.step(&to_child1, 0.1);
        }
        assert_eq!(controller.node_network(1).unwrap().state(), &[0.0]);
        assert_eq!(controller.last_outputs(1).unwrap(), &[0.0, 0.0]);
        assert!(controller.node_network(2).unwrap().state()[0] > 0.0);

        let reactivated = controller.step(&to_child0, 0.1);
        assert_eq!(reactivated, first_output);
        assert_eq!(controller.node_network(2).unwrap().state(), &[0.0]);
    }

    #[test]
    fn reset_controller_replays_identically() {
        let file = rescue_tree();
        let genes = random_genes(file.free_node_topology().unwrap().1, 7);
        let mut controller = Controller::new(&file, Some(&genes)).unwrap();
        let frames: Vec<SensorFrame> = (0..200u32)
            .map(|cycle| {
                let t = cycle as f32;
                frame(
                    [(t * 0.1).sin().abs(), (t * 0.07).cos().abs(), 0.1, 0.9],
                    [
                        (cycle % 30 < 15) as u8 as f32,
                        (cycle % 50 < 15) as u8 as f32,
                    ],
                    (cycle % 70 > 35) as u8 as f32,
                )
            })
            .collect();
        let first: Vec<WheelOutputs> = frames.iter().map(|f| controller.step(f, 0.1)).collect();
        controller.reset();
        assert!(controller.active_path().is_empty());
        assert_eq!(controller.root_choice(), None);
        let mut clone = controller.clone();
        let second: Vec<WheelOutputs> = frames.iter().map(|f| controller.step(f, 0.1)).collect();
        let cloned: Vec<WheelOutputs> = frames.iter().map(|f| clone.step(f, 0.1)).collect();
        assert_eq!(first, second);
        assert_eq!(first, cloned);
        assert!(
            first
                .iter()
                .all(|w| (0.0..=1.0).contains(&w.left) && (0.0..=1.0).contains(&w.right))
        );
    }

    #[test]
    fn depth_three_tree_with_independent_topologies() {
        const IR: InputGroup = InputGroup::IR;
        const LIGHT: InputGroup = InputGroup::LIGHT;
        const NEAR_ROBOT: InputGroup = InputGroup::NEAR_ROBOT;
        // Pre-order: 0 root, 1 middle, 2 leaf_a, 3 leaf_b, 4 leaf_c.
        let mut root = arbitrator(
            "root",
            &[IR, LIGHT],
            4,
            1,
            vec![
                arbitrator(
                    "middle",
                    &[NEAR_ROBOT],
                    2,
                    2,
                    vec![
                        primitive("leaf_a", &[IR], 3, 3),
                        primitive("leaf_b", &[LIGHT], 1, 4),
                    ],
                ),
                primitive("leaf_c", &[IR, LIGHT, NEAR_ROBOT], 5, 5),
            ],
        );
        // Force the choices with output biases: root -> middle, middle -> leaf_b.
        let root_layout = root.topology().layout();
        let root_genes = root.genome.as_mut().unwrap();
        root_genes[root_layout.output_weights].fill(0.0);
        root_genes[root_layout.output_biases.clone()].copy_from_slice(&[10.0, -10.0]);
        let middle = &mut root.children[0];
        let middle_layout = middle.topology().layout();
        let middle_genes = middle.genome.as_mut().unwrap();
        middle_genes[middle_layout.output_weights].fill(0.0);
        middle_genes[middle_layout.output_biases.clone()].copy_from_slice(&[-10.0, 10.0]);
        let file = ControllerFile::new(root);

        let mut controller = Controller::new(&file, None).unwrap();
        assert_eq!(controller.n_nodes(), 5);
        assert_eq!(
            controller.node_names(),
            ["root", "middle", "leaf_a", "leaf_b", "leaf_c"]
        );
        assert_eq!(controller.node_path(3), Some("root/middle/leaf_b"));
        assert_eq!(controller.node_path(5), None);
        let paths: Vec<Option<&str>> = (0..5).map(|idx| controller.node_path(idx)).collect();
        let file_paths = file.node_paths();
        assert_eq!(
            paths,
            file_paths
                .iter()
                .map(|p| Some(p.as_str()))
                .collect::<Vec<_>>(),
            "the file's paths come in node-index order"
        );
        assert_eq!(controller.node_children(0), Some(&[1, 4][..]));
        assert_eq!(controller.node_children(1), Some(&[2, 3][..]));
        let topologies: Vec<String> = (0..5)
            .map(|idx| controller.node_network(idx).unwrap().topology().to_string())
            .collect();
        assert_eq!(topologies, ["6-4-2", "1-2-2", "4-3-2", "2-1-2", "7-5-2"]);
        assert_eq!(controller.node_kind(1), Some(NodeKind::Arbitrator));

        let sensors = frame([0.3, 0.0, 0.8, 0.1], [1.0, 0.0], 1.0);
        let capacity_before = controller.active_path.capacity();
        for _ in 0..5 {
            let wheels = controller.step(&sensors, 0.1);
            assert_eq!(controller.active_path(), &[0, 1, 3]);
            assert_eq!(controller.root_choice(), Some(0));
            assert_eq!(controller.active_child(1), Some(1));
            assert_eq!(
                controller.last_outputs(3).unwrap(),
                &[wheels.left, wheels.right]
            );
        }
        assert_eq!(controller.active_path.capacity(), capacity_before);
        // Inactive nodes never stepped.
        assert_eq!(controller.last_outputs(2).unwrap(), &[0.0, 0.0]);
        assert_eq!(controller.last_outputs(4).unwrap(), &[0.0, 0.0]);
        assert_eq!(controller.node_network(4).unwrap().state(), &[0.0; 5]);
    }

    #[test]
    fn primitive_root_drives_the_wheels_directly() {
        let file = ControllerFile::new(primitive("alone", &[InputGroup::IR], 3, 11));
        let mut controller = Controller::new(&file, None).unwrap();
        let wheels = controller.step(&frame([0.5; 4], [0.0; 2], 0.0), 0.1);
        assert_eq!(controller.root_choice(), None);
        assert_eq!(controller.active_path(), &[0]);
        assert_eq!(
            controller.last_outputs(0).unwrap(),
            &[wheels.left, wheels.right]
        );
    }

    #[test]
    fn controller_is_clone_and_send() {
        fn assert_clone_send<T: Clone + Send + Sync>() {}
        assert_clone_send::<Controller>();
        assert_clone_send::<ControllerFile>();
    }
}
