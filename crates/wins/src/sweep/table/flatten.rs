//! Flattening a serialized value into `(path, cell)` pairs (module doc of [`super`]): the leaves'
//! paths in the JSON text's order, their values from the tree, and the cells' text.

use std::fmt;

use serde::Serialize;
use serde::de::{DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};
use serde_json::Value;

/// One step of a path into a serialized value.
#[derive(Clone, Debug, PartialEq)]
enum Step {
    Key(String),
    Index(usize),
}

/// Records the path of every leaf of a JSON text, in the text's order.
struct Leaves<'a> {
    path: Vec<Step>,
    out: &'a mut Vec<Vec<Step>>,
}

impl<'de> DeserializeSeed<'de> for Leaves<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl Leaves<'_> {
    fn leaf<E>(self) -> Result<(), E> {
        self.out.push(self.path);
        Ok(())
    }

    fn child(&mut self, step: Step) -> Leaves<'_> {
        let mut path = self.path.clone();
        path.push(step);
        Leaves {
            path,
            out: self.out,
        }
    }
}

impl<'de> Visitor<'de> for Leaves<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<(), E> {
        self.leaf()
    }
    fn visit_i64<E>(self, _: i64) -> Result<(), E> {
        self.leaf()
    }
    fn visit_u64<E>(self, _: u64) -> Result<(), E> {
        self.leaf()
    }
    fn visit_f64<E>(self, _: f64) -> Result<(), E> {
        self.leaf()
    }
    fn visit_str<E>(self, _: &str) -> Result<(), E> {
        self.leaf()
    }
    fn visit_unit<E>(self) -> Result<(), E> {
        self.leaf()
    }
    fn visit_none<E>(self) -> Result<(), E> {
        self.leaf()
    }
    fn visit_seq<A: SeqAccess<'de>>(mut self, mut seq: A) -> Result<(), A::Error> {
        let mut i = 0;
        while seq.next_element_seed(self.child(Step::Index(i)))?.is_some() {
            i += 1;
        }
        Ok(())
    }
    fn visit_map<A: MapAccess<'de>>(mut self, mut map: A) -> Result<(), A::Error> {
        while let Some(key) = map.next_key::<String>()? {
            map.next_value_seed(self.child(Step::Key(key)))?;
        }
        Ok(())
    }
}

/// The leaves of `value` serialized as JSON, `(path, cell)` in serialization order: paths
/// `.`-joined, numbers as `serde_json` writes them, null as an empty cell. An empty array or
/// map has no leaf.
pub fn flatten<T: Serialize>(value: &T) -> Result<Vec<(String, String)>, serde_json::Error> {
    // The order comes from the text (serde_json's maps are sorted), the values from the tree,
    // which keeps each f64 exactly (parsing the text back could be 1 ulp off).
    let text = serde_json::to_string(value)?;
    let mut paths = Vec::new();
    let mut de = serde_json::Deserializer::from_str(&text);
    Leaves {
        path: Vec::new(),
        out: &mut paths,
    }
    .deserialize(&mut de)?;
    let tree = serde_json::to_value(value)?;
    Ok(paths
        .into_iter()
        .map(|path| {
            let name = path
                .iter()
                .map(|s| match s {
                    Step::Key(k) => k.clone(),
                    Step::Index(i) => i.to_string(),
                })
                .collect::<Vec<_>>()
                .join(".");
            let leaf = path.iter().try_fold(&tree, |v, s| match s {
                Step::Key(k) => v.get(k.as_str()),
                Step::Index(i) => v.get(*i),
            });
            (name, leaf.map(cell).unwrap_or_default())
        })
        .collect())
}

fn cell(v: &Value) -> String {
    match v {
        Value::Null => String::new(),
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// A number as `serde_json` writes it (shortest round trip); empty for none or a non-finite one.
pub fn number_cell(x: Option<f64>) -> String {
    x.and_then(serde_json::Number::from_f64)
        .map(|n| n.to_string())
        .unwrap_or_default()
}
