//! Reading the model files: thinc's serialised models (msgpack maps of
//! nodes, attrs and numpy params) and srsly's msgpack data.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use rmpv::Value;

use super::EnError;

/// A float32 array from a thinc model, row-major.
#[derive(Debug, Clone)]
pub struct Array {
    /// The dimensions.
    pub shape: Vec<usize>,
    /// The values, row-major.
    pub data: Vec<f32>,
}

/// One node of a thinc model: its name, dims, attrs and params.
#[derive(Debug, Clone)]
pub struct Node {
    /// The layer's name, e.g. `hashembed`.
    pub name: String,
    /// Its dims (`nO`, `nI`, ...), where set.
    pub dims: HashMap<String, i64>,
    /// Its attrs, decoded from their msgpack bytes.
    pub attrs: HashMap<String, Value>,
    /// Its params by name.
    pub params: HashMap<String, Array>,
}

/// Reads a file and decodes it as one msgpack value.
pub fn read_msgpack(path: &Path) -> Result<Value, EnError> {
    let bytes = std::fs::read(path).map_err(|e| EnError::missing(path, &e))?;
    rmpv::decode::read_value(&mut bytes.as_slice())
        .map_err(|e| EnError::corrupt(path, &format!("not msgpack: {e}")))
}

/// The text of a msgpack string or binary value.
pub fn as_text(value: &Value) -> Option<&str> {
    match value {
        Value::String(s) => s.as_str(),
        Value::Binary(b) => std::str::from_utf8(b).ok(),
        _ => None,
    }
}

/// Looks up a key (string or binary) in a msgpack map.
pub fn get<'a>(map: &'a Value, key: &str) -> Option<&'a Value> {
    map.as_map()?
        .iter()
        .find(|(k, _)| as_text(k) == Some(key))
        .map(|(_, v)| v)
}

/// A thinc model file, as the list of its nodes in walk order.
pub struct ThincModel {
    /// The file it came from, for error messages.
    pub path: PathBuf,
    /// The nodes in the order thinc walks them.
    pub nodes: Vec<Node>,
}

impl ThincModel {
    /// Loads a thinc `model` file.
    pub fn load(path: &Path) -> Result<Self, EnError> {
        let root = read_msgpack(path)?;
        let bad = |what: &str| EnError::corrupt(path, what);
        let nodes = get(&root, "nodes").and_then(Value::as_array);
        let attrs = get(&root, "attrs").and_then(Value::as_array);
        let params = get(&root, "params").and_then(Value::as_array);
        let (Some(nodes), Some(attrs), Some(params)) = (nodes, attrs, params) else {
            return Err(bad("not a thinc model (no nodes/attrs/params)"));
        };
        if nodes.len() != attrs.len() || nodes.len() != params.len() {
            return Err(bad("nodes, attrs and params differ in length"));
        }
        let mut out = Vec::with_capacity(nodes.len());
        for ((node, attr), param) in nodes.iter().zip(attrs).zip(params) {
            let name = get(node, "name")
                .and_then(as_text)
                .ok_or_else(|| bad("a node has no name"))?
                .to_string();
            let mut dims = HashMap::new();
            if let Some(map) = get(node, "dims").and_then(Value::as_map) {
                for (k, v) in map {
                    if let (Some(k), Some(v)) = (as_text(k), v.as_i64()) {
                        dims.insert(k.to_string(), v);
                    }
                }
            }
            let mut node_attrs = HashMap::new();
            for (k, v) in attr.as_map().into_iter().flatten() {
                let (Some(k), Value::Binary(b)) = (as_text(k), v) else {
                    continue;
                };
                let value = rmpv::decode::read_value(&mut b.as_slice())
                    .map_err(|_| bad("an attr is not msgpack"))?;
                node_attrs.insert(k.to_string(), value);
            }
            let mut node_params = HashMap::new();
            for (k, v) in param.as_map().into_iter().flatten() {
                let Some(k) = as_text(k) else { continue };
                node_params.insert(k.to_string(), decode_array(v).map_err(|e| bad(&e))?);
            }
            out.push(Node {
                name,
                dims,
                attrs: node_attrs,
                params: node_params,
            });
        }
        Ok(Self {
            path: path.to_path_buf(),
            nodes: out,
        })
    }

    /// The nodes with this exact name, in walk order.
    pub fn named(&self, name: &str) -> Vec<&Node> {
        self.nodes.iter().filter(|n| n.name == name).collect()
    }

    /// A param of a node, checked against the expected shape.
    pub fn param<'a>(
        &self,
        node: &'a Node,
        name: &str,
        shape: &[usize],
    ) -> Result<&'a Array, EnError> {
        let array = node.params.get(name).ok_or_else(|| {
            EnError::corrupt(&self.path, &format!("{} has no param {name}", node.name))
        })?;
        if array.shape != shape {
            return Err(EnError::corrupt(
                &self.path,
                &format!(
                    "{} param {name} has shape {:?}, expected {shape:?}",
                    node.name, array.shape
                ),
            ));
        }
        Ok(array)
    }
}

fn decode_array(value: &Value) -> Result<Array, String> {
    let dtype = get(value, "type").and_then(as_text);
    if dtype != Some("<f4") {
        return Err(format!("a param has dtype {dtype:?}, expected <f4"));
    }
    let shape: Vec<usize> = get(value, "shape")
        .and_then(Value::as_array)
        .ok_or("a param has no shape")?
        .iter()
        .map(|d| d.as_u64().map(|d| d as usize))
        .collect::<Option<_>>()
        .ok_or("a param has a bad shape")?;
    let bytes = match get(value, "data") {
        Some(Value::Binary(b)) => b,
        _ => return Err("a param has no data".to_string()),
    };
    let n: usize = shape.iter().product();
    if bytes.len() != n * 4 {
        return Err(format!(
            "a param has {} bytes for shape {shape:?}",
            bytes.len()
        ));
    }
    let data = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Ok(Array { shape, data })
}
