//! `hevo.Controller`: a controller file (`hevo.controller/1`) as a Python object. The tree of
//! nodes with their kinds, inputs and genome lengths; each node's genome as a numpy array to
//! read and set; a copy with one node's genome removed, the template `hevo.evaluate` fills with
//! each genome. Every change is checked as loading a file is, so a saved controller always loads.

use crate::ControllerError;
use hevo_sim_core::{ControllerFile, NodeKind, NodeSpec};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A controller tree: primitives that drive the wheels and arbitrators that choose among their
/// children, each a CTRNN with its genome. Load one with `Controller.load(path)`.
#[pyclass(module = "hevo")]
#[derive(Debug, Clone)]
pub struct Controller {
    pub(crate) file: ControllerFile,
}

/// The node at `path` (`rescue/solve_maze/turn_left`; the root's path is its name).
fn node_at<'a>(root: &'a mut NodeSpec, path: &str) -> Option<&'a mut NodeSpec> {
    let mut parts = path.split('/');
    if parts.next()? != root.name {
        return None;
    }
    let mut node = root;
    for part in parts {
        node = node.children.iter_mut().find(|child| child.name == part)?;
    }
    Some(node)
}

fn no_node(file: &ControllerFile, path: &str) -> PyErr {
    ControllerError::new_err(format!(
        "no node '{path}' in the controller; its nodes: {}",
        file.node_paths().join(", ")
    ))
}

impl Controller {
    /// The node at `path`, or the root when `None`.
    fn node_mut(&mut self, path: Option<&str>) -> PyResult<&mut NodeSpec> {
        let path = path.map_or_else(|| self.file.root.name.clone(), str::to_string);
        if node_at(&mut self.file.root, &path).is_none() {
            return Err(no_node(&self.file, &path));
        }
        Ok(node_at(&mut self.file.root, &path).expect("checked just above"))
    }

    /// Applies `change` to a copy and keeps it only when the copy still validates.
    fn changed(&self, change: impl FnOnce(&mut ControllerFile) -> PyResult<()>) -> PyResult<Self> {
        let mut file = self.file.clone();
        change(&mut file)?;
        file.validate()
            .map_err(|error| ControllerError::new_err(crate::message(&error)))?;
        Ok(Controller { file })
    }
}

#[pymethods]
impl Controller {
    /// Reads a controller file (JSON), checking it as `hevo eval` does; raises ControllerError
    /// naming the file and node when it cannot be used. The file may have one node without a
    /// genome (a template).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let file = hevo_engine::inputs::read_controller(&path)
            .map_err(|error| ControllerError::new_err(crate::message(&error)))?;
        Ok(Controller { file })
    }

    /// Parses a controller from its JSON text.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let file = ControllerFile::from_json_str(text)
            .map_err(|error| ControllerError::new_err(crate::message(&error)))?;
        Ok(Controller { file })
    }

    /// The controller file's JSON text, as `save` writes it.
    fn to_json(&self) -> PyResult<String> {
        self.file
            .to_json_pretty()
            .map_err(|error| ControllerError::new_err(crate::message(&error)))
    }

    /// Writes the controller file (JSON), atomically: a reader never sees half a file.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        let text = self.to_json()?;
        hevo_engine::store::write_atomic(&path, format!("{text}\n").as_bytes()).map_err(|error| {
            crate::RunError::new_err(format!("cannot write {}: {error}", path.display()))
        })
    }

    /// Every node's path in pre-order (the root first): the order of node indices in traces.
    #[getter]
    fn node_paths(&self) -> Vec<String> {
        self.file.node_paths()
    }

    /// The path of the node without a genome, if there is one (the node `evaluate` fills).
    #[getter]
    fn free_node(&self) -> Option<String> {
        self.file.free_node_topology().map(|(path, _)| path)
    }

    /// Genes the free node takes (the width of the genomes array `evaluate` wants); 0 when
    /// every node has its genome.
    #[getter]
    fn n_genes(&self) -> usize {
        self.file
            .free_node_topology()
            .map_or(0, |(_, topology)| topology.n_genes())
    }

    /// The tree as nested dicts: name, path, kind (`primitive` or `arbitrator`), inputs,
    /// hidden neurons, topology (`inputs-hidden-outputs`), genome length, whether it has its
    /// genome, and children.
    fn tree<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        fn describe<'py>(
            py: Python<'py>,
            node: &NodeSpec,
            path: &str,
        ) -> PyResult<Bound<'py, PyDict>> {
            let dict = PyDict::new(py);
            let topology = node.topology();
            dict.set_item("name", &node.name)?;
            dict.set_item("path", path)?;
            dict.set_item(
                "kind",
                match node.kind {
                    NodeKind::Primitive => "primitive",
                    NodeKind::Arbitrator => "arbitrator",
                },
            )?;
            let inputs: Vec<String> = node
                .inputs
                .iter()
                .map(|group| {
                    serde_json::to_value(group)
                        .ok()
                        .and_then(|value| value.as_str().map(str::to_string))
                        .unwrap_or_default()
                })
                .collect();
            dict.set_item("inputs", inputs)?;
            dict.set_item("hidden", node.hidden)?;
            dict.set_item("topology", topology.to_string())?;
            dict.set_item("n_genes", topology.n_genes())?;
            dict.set_item("has_genome", node.genome.is_some())?;
            let children = node
                .children
                .iter()
                .map(|child| describe(py, child, &format!("{path}/{}", child.name)))
                .collect::<PyResult<Vec<_>>>()?;
            dict.set_item("children", children)?;
            Ok(dict)
        }
        describe(py, &self.file.root, &self.file.root.name)
    }

    /// The genome length of the node at `node` (a path; the root when omitted).
    #[pyo3(signature = (node=None))]
    fn genome_length(&mut self, node: Option<&str>) -> PyResult<usize> {
        Ok(self.node_mut(node)?.topology().n_genes())
    }

    /// A copy of the genome of the node at `node` (the root when omitted) as a float32 array,
    /// or None for the free node.
    #[pyo3(signature = (node=None))]
    fn genome<'py>(
        &mut self,
        py: Python<'py>,
        node: Option<&str>,
    ) -> PyResult<Option<Bound<'py, PyArray1<f32>>>> {
        Ok(self
            .node_mut(node)?
            .genome
            .as_deref()
            .map(|genes| PyArray1::from_slice(py, genes)))
    }

    /// Sets the genome of the node at `node` (the root when omitted) from an array of its
    /// genome length (any float dtype; float64 rounds to the nearest float32); raises
    /// ControllerError (and changes nothing) when the genes do not fit.
    #[pyo3(signature = (genes, node=None))]
    fn set_genome(&mut self, genes: &Bound<'_, PyAny>, node: Option<&str>) -> PyResult<()> {
        let genes = crate::genomes::genes_of(genes)?;
        let path = node.map(str::to_string);
        let mut copy = self.clone();
        copy.node_mut(path.as_deref())?.genome = Some(genes);
        let updated = copy.changed(|_| Ok(()))?;
        self.file = updated.file;
        Ok(())
    }

    /// A copy of this controller with the genome of the node at `node` (the root when omitted)
    /// removed: a template for `hevo.evaluate`, which fills that node with each genome.
    #[pyo3(signature = (node=None))]
    fn without_genome(&self, node: Option<&str>) -> PyResult<Self> {
        let mut copy = self.clone();
        let path = node.map(str::to_string);
        copy.node_mut(path.as_deref())?.genome = None;
        copy.changed(|_| Ok(()))
    }

    /// A copy of this template with its free node's genome filled in (how an evolved genome is
    /// saved as a complete controller); any float dtype, as `set_genome`.
    fn with_genome(&self, genes: &Bound<'_, PyAny>) -> PyResult<Self> {
        let genes = crate::genomes::genes_of(genes)?;
        let file = self
            .file
            .with_free_genome(&genes)
            .map_err(|error| ControllerError::new_err(crate::message(&error)))?;
        Ok(Controller { file })
    }

    /// The content hash hevo's caches and fingerprints use (16 hex digits).
    #[getter]
    fn content_hash(&self) -> String {
        self.file.content_hash()
    }

    fn __eq__(&self, other: PyRef<'_, Controller>) -> bool {
        self.file.content_hash() == other.file.content_hash()
    }

    fn __repr__(&self) -> String {
        let free = self
            .free_node()
            .map(|path| format!(", free node '{path}'"))
            .unwrap_or_default();
        format!(
            "Controller('{}', {} node(s){free})",
            self.file.root.name,
            self.file.node_paths().len()
        )
    }
}
