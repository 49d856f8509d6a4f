//! Random damage to a dataset folder's files: IMU rows, manifest values, log bytes, truth and
//! barometer lines. Each [`Mutation`] prints (`Debug`) as what it did, so a failing case names it.

use std::fs;
use std::path::Path;

use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::{Index, select};

/// Replacement texts for an IMU, truth or barometer field.
const FIELDS: &[&str] = &[
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "",
    " ",
    "garbage",
    "0x10",
    "1,2",
    "9223372036854775807",
    "-9223372036854775808",
    "99999999999999999999",
    "-1",
    "2.5",
];

/// Replacement lines (a line's whole text).
const LINES: &[&str] = &[
    "",
    "#",
    "garbage",
    ",,,,,,",
    "1 2 3",
    "nan nan nan",
    "\u{feff}x",
];

/// Shifts of IMU timestamps, ns: a period back or forward, seconds, and far out.
const SHIFTS: &[i64] = &[
    -5_000_000,
    -2_500_000,
    1,
    5_000_000,
    -1_000_000_000,
    3_000_000_000,
    -3_000_000_000_000,
    4_611_686_018_427_387_903,
    -4_611_686_018_427_387_904,
];

/// A position in a list of rows, lines or bytes: either end (where damage tells most: the first
/// sample sets the time origin, the last ends the flight) or anywhere.
#[derive(Clone, Copy, Debug)]
pub enum At {
    /// The first.
    First,
    /// The last (for a cut: the end, nothing cut).
    Last,
    /// Any.
    Any(Index),
}

impl At {
    /// The position in a list of `len > 0` items.
    fn index(&self, len: usize) -> usize {
        match self {
            Self::First => 0,
            Self::Last => len - 1,
            Self::Any(i) => i.index(len),
        }
    }
}

/// A position, an end one time in three.
fn at() -> impl Strategy<Value = At> {
    prop_oneof![
        1 => Just(At::First),
        1 => Just(At::Last),
        4 => any::<Index>().prop_map(At::Any),
    ]
}

/// One change to a dataset folder.
#[derive(Clone, Debug)]
pub enum Mutation {
    /// Delete `n` IMU rows from row `at`.
    ImuDelete { at: At, n: usize },
    /// Repeat `n` IMU rows from row `at` right after them.
    ImuDuplicate { at: At, n: usize },
    /// Swap two IMU rows.
    ImuSwap { a: At, b: At },
    /// Replace one field of an IMU row.
    ImuField {
        row: At,
        field: usize,
        value: &'static str,
    },
    /// Add `by_ns` to the timestamps of the rows from `from` on.
    ImuShift { from: At, by_ns: i64 },
    /// Cut the IMU file at a byte (mid-line, most likely).
    ImuCut { at: At },
    /// Set a manifest value (any key, arrays included) to another value.
    TomlSet { key: Index, value: toml::Value },
    /// Multiply a numeric manifest value.
    TomlScale { key: Index, by: f64 },
    /// Remove a manifest key.
    TomlRemove { key: Index },
    /// Add an unknown key to a manifest table.
    TomlBogus { table: Index },
    /// XOR `n` log bytes from `at` with `xor`.
    LogFlip { at: At, n: usize, xor: u8 },
    /// Cut the log at a byte.
    LogTruncate { at: At },
    /// Insert bytes into the log.
    LogInsert { at: At, bytes: Vec<u8> },
    /// Copy `len` log bytes from `from` to `to` (a log written twice, in part).
    LogDuplicate { from: At, len: usize, to: At },
    /// Cut the truth poses at a byte.
    TruthTruncate { at: At },
    /// Replace a truth pose line.
    TruthLine { line: At, text: &'static str },
    /// Replace one field of a truth pose line.
    TruthField {
        line: At,
        field: usize,
        value: &'static str,
    },
    /// Replace a barometer line's field.
    BaroField {
        line: At,
        field: usize,
        value: &'static str,
    },
}

/// Manifest values to set.
fn toml_value() -> impl Strategy<Value = toml::Value> {
    use toml::Value;
    prop_oneof![
        select(vec![
            -1.0,
            0.0,
            -0.0,
            1e-300,
            0.5,
            3.0,
            1e308,
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
        ])
        .prop_map(Value::Float),
        select(vec![-1i64, 0, 1, 2, 3, 4, 1 << 40, i64::MAX, i64::MIN]).prop_map(Value::Integer),
        Just(Value::String("x".into())),
        Just(Value::String(String::new())),
        Just(Value::Boolean(true)),
        Just(Value::Array(Vec::new())),
        Just(Value::Table(toml::Table::new())),
    ]
}

/// Any mutation.
pub fn mutation() -> impl Strategy<Value = Mutation> {
    let field = || select(FIELDS.to_vec());
    prop_oneof![
        (at(), 1usize..40).prop_map(|(at, n)| Mutation::ImuDelete { at, n }),
        (at(), 1usize..40).prop_map(|(at, n)| Mutation::ImuDuplicate { at, n }),
        (at(), at()).prop_map(|(a, b)| Mutation::ImuSwap { a, b }),
        (at(), 0usize..7, field()).prop_map(|(row, field, value)| Mutation::ImuField {
            row,
            field,
            value
        }),
        (at(), select(SHIFTS.to_vec()))
            .prop_map(|(from, by_ns)| Mutation::ImuShift { from, by_ns }),
        at().prop_map(|at| Mutation::ImuCut { at }),
        (any::<Index>(), toml_value()).prop_map(|(key, value)| Mutation::TomlSet { key, value }),
        (any::<Index>(), select(vec![-1.0, 0.0, 0.5, 2.0, 1e6, 1e-6]))
            .prop_map(|(key, by)| Mutation::TomlScale { key, by }),
        any::<Index>().prop_map(|key| Mutation::TomlRemove { key }),
        any::<Index>().prop_map(|table| Mutation::TomlBogus { table }),
        (at(), 1usize..16, 1u8..=255).prop_map(|(at, n, xor)| Mutation::LogFlip { at, n, xor }),
        at().prop_map(|at| Mutation::LogTruncate { at }),
        (at(), vec(any::<u8>(), 1..64)).prop_map(|(at, bytes)| Mutation::LogInsert { at, bytes }),
        (at(), 1usize..3000, at()).prop_map(|(from, len, to)| Mutation::LogDuplicate {
            from,
            len,
            to
        }),
        at().prop_map(|at| Mutation::TruthTruncate { at }),
        (at(), select(LINES.to_vec())).prop_map(|(line, text)| Mutation::TruthLine { line, text }),
        (at(), 0usize..8, field()).prop_map(|(line, field, value)| Mutation::TruthField {
            line,
            field,
            value
        }),
        (at(), 0usize..2, field()).prop_map(|(line, field, value)| Mutation::BaroField {
            line,
            field,
            value
        }),
    ]
}

impl Mutation {
    /// Applies the change to the dataset folder `dir` (as the simulator writes it).
    pub fn apply(&self, dir: &Path) {
        let imu = dir.join("imu.csv");
        let log = dir.join("ap0.dat");
        let poses = dir.join("truth").join("poses.tum");
        match self {
            Self::ImuDelete { at, n } => edit_rows(&imu, 1, |rows| {
                let a = at.index(rows.len());
                rows.drain(a..(a + n).min(rows.len()));
            }),
            Self::ImuDuplicate { at, n } => edit_rows(&imu, 1, |rows| {
                let a = at.index(rows.len());
                let copy: Vec<String> = rows[a..(a + n).min(rows.len())].to_vec();
                rows.splice(a + copy.len()..a + copy.len(), copy);
            }),
            Self::ImuSwap { a, b } => edit_rows(&imu, 1, |rows| {
                let (a, b) = (a.index(rows.len()), b.index(rows.len()));
                rows.swap(a, b);
            }),
            Self::ImuField { row, field, value } => edit_rows(&imu, 1, |rows| {
                let r = row.index(rows.len());
                rows[r] = set_field(&rows[r], ',', *field, value);
            }),
            Self::ImuShift { from, by_ns } => edit_rows(&imu, 1, |rows| {
                let a = from.index(rows.len());
                for row in &mut rows[a..] {
                    let t = row.split(',').next().and_then(|t| t.parse::<i64>().ok());
                    if let Some(t) = t {
                        let shifted = t.saturating_add(*by_ns).to_string();
                        *row = set_field(row, ',', 0, &shifted);
                    }
                }
            }),
            Self::ImuCut { at } => edit_bytes(&imu, |b| b.truncate(at.index(b.len() + 1))),
            Self::TomlSet { key, value } => edit_toml(dir, |t| {
                if let Some(slot) = leaf(t, key) {
                    *slot = value.clone();
                }
            }),
            Self::TomlScale { key, by } => edit_toml(dir, |t| match leaf(t, key) {
                Some(toml::Value::Float(v)) => *v *= by,
                Some(toml::Value::Integer(v)) => *v = (*v as f64 * by) as i64,
                _ => {}
            }),
            Self::TomlRemove { key } => edit_toml(dir, |t| remove_leaf(t, key)),
            Self::TomlBogus { table } => edit_toml(dir, |t| {
                if let Some(t) = pick_table(t, table) {
                    t.insert("bogus_key".into(), toml::Value::Integer(1));
                }
            }),
            Self::LogFlip { at, n, xor } => edit_bytes(&log, |b| {
                if b.is_empty() {
                    return;
                }
                let a = at.index(b.len());
                let end = (a + n).min(b.len());
                b[a..end].iter_mut().for_each(|x| *x ^= xor);
            }),
            Self::LogTruncate { at } => edit_bytes(&log, |b| b.truncate(at.index(b.len() + 1))),
            Self::LogInsert { at, bytes } => edit_bytes(&log, |b| {
                let a = at.index(b.len() + 1);
                b.splice(a..a, bytes.iter().copied());
            }),
            Self::LogDuplicate { from, len, to } => edit_bytes(&log, |b| {
                if b.is_empty() {
                    return;
                }
                let a = from.index(b.len());
                let copy = b[a..(a + len).min(b.len())].to_vec();
                let t = to.index(b.len() + 1);
                b.splice(t..t, copy);
            }),
            Self::TruthTruncate { at } => {
                edit_bytes(&poses, |b| b.truncate(at.index(b.len() + 1)));
            }
            Self::TruthLine { line, text } => edit_rows(&poses, 0, |rows| {
                let r = line.index(rows.len());
                rows[r] = (*text).to_string();
            }),
            Self::TruthField { line, field, value } => edit_rows(&poses, 0, |rows| {
                let r = line.index(rows.len());
                rows[r] = set_field(&rows[r], ' ', *field, value);
            }),
            Self::BaroField { line, field, value } => {
                edit_rows(&dir.join("baro.csv"), 0, |rows| {
                    let r = line.index(rows.len());
                    rows[r] = set_field(&rows[r], ',', *field, value);
                });
            }
        }
    }
}

/// `line` with its `field`-th `sep`-separated field replaced (appended when it has fewer).
fn set_field(line: &str, sep: char, field: usize, value: &str) -> String {
    let mut fields: Vec<&str> = line.split(sep).collect();
    match fields.get_mut(field) {
        Some(f) => *f = value,
        None => fields.push(value),
    }
    fields.join(&sep.to_string())
}

/// Rewrites the lines of a text file after its first `keep` lines with `edit` (which never sees
/// an empty list); each line written back with a line end. A file that is missing or not text
/// is left as it is.
fn edit_rows(path: &Path, keep: usize, edit: impl FnOnce(&mut Vec<String>)) {
    let Ok(text) = fs::read_to_string(path) else {
        return;
    };
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.len() <= keep {
        return;
    }
    let mut rows = lines.split_off(keep);
    edit(&mut rows);
    lines.extend(rows);
    let mut out = lines.join("\n");
    out.push('\n');
    fs::write(path, out).expect("writing a mutated file");
}

/// Rewrites a file's bytes with `edit` (a missing file is left missing).
fn edit_bytes(path: &Path, edit: impl FnOnce(&mut Vec<u8>)) {
    let Ok(mut bytes) = fs::read(path) else {
        return;
    };
    edit(&mut bytes);
    fs::write(path, bytes).expect("writing a mutated file");
}

/// Rewrites `dataset.toml` with `edit` over its parsed table (a manifest that no longer parses
/// is left as it is).
fn edit_toml(dir: &Path, edit: impl FnOnce(&mut toml::Table)) {
    let path = dir.join("dataset.toml");
    let Ok(text) = fs::read_to_string(&path) else {
        return;
    };
    let Ok(mut table) = toml::from_str::<toml::Table>(&text) else {
        return;
    };
    edit(&mut table);
    let text = toml::to_string(&table).expect("a TOML table serializes");
    fs::write(path, text).expect("writing the mutated manifest");
}

/// Every leaf value (not a non-empty table or array) under `value`, in document order.
fn leaves<'a>(value: &'a mut toml::Value, out: &mut Vec<&'a mut toml::Value>) {
    let nested = match value {
        toml::Value::Table(t) => !t.is_empty(),
        toml::Value::Array(a) => !a.is_empty(),
        _ => false,
    };
    if !nested {
        out.push(value);
        return;
    }
    match value {
        toml::Value::Table(t) => t.iter_mut().for_each(|(_, v)| leaves(v, out)),
        toml::Value::Array(a) => a.iter_mut().for_each(|v| leaves(v, out)),
        _ => {}
    }
}

/// The leaf `key` picks.
fn leaf<'a>(table: &'a mut toml::Table, key: &Index) -> Option<&'a mut toml::Value> {
    let mut all = Vec::new();
    table.iter_mut().for_each(|(_, v)| leaves(v, &mut all));
    if all.is_empty() {
        return None;
    }
    let k = key.index(all.len());
    all.into_iter().nth(k)
}

/// A step from a table to one of its tables: a key, then an index when it names an array.
type Step = (String, Option<usize>);

/// The path of every table, the top one (empty path) first.
fn table_paths(table: &toml::Table, prefix: &[Step], out: &mut Vec<Vec<Step>>) {
    out.push(prefix.to_vec());
    for (k, v) in table {
        let mut path = prefix.to_vec();
        match v {
            toml::Value::Table(t) => {
                path.push((k.clone(), None));
                table_paths(t, &path, out);
            }
            toml::Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    if let toml::Value::Table(t) = x {
                        let mut p = path.clone();
                        p.push((k.clone(), Some(i)));
                        table_paths(t, &p, out);
                    }
                }
            }
            _ => {}
        }
    }
}

/// The table at `path`.
fn table_at<'a>(mut table: &'a mut toml::Table, path: &[Step]) -> Option<&'a mut toml::Table> {
    for (k, i) in path {
        let v = table.get_mut(k)?;
        let v = match i {
            Some(i) => v.as_array_mut()?.get_mut(*i)?,
            None => v,
        };
        table = v.as_table_mut()?;
    }
    Some(table)
}

/// The keys of the table at `path`.
fn keys_at(mut table: &toml::Table, path: &[Step]) -> Vec<String> {
    for (k, i) in path {
        let v = table.get(k);
        let v = match i {
            Some(i) => v.and_then(|v| v.as_array()).and_then(|a| a.get(*i)),
            None => v,
        };
        match v.and_then(|v| v.as_table()) {
            Some(t) => table = t,
            None => return Vec::new(),
        }
    }
    table.keys().cloned().collect()
}

/// The table `index` picks among every table.
fn pick_table<'a>(table: &'a mut toml::Table, index: &Index) -> Option<&'a mut toml::Table> {
    let mut paths = Vec::new();
    table_paths(table, &[], &mut paths);
    let path = &paths[index.index(paths.len())];
    table_at(table, path)
}

/// Removes the key (of any table) that `key` picks among every table's keys.
fn remove_leaf(table: &mut toml::Table, key: &Index) {
    let mut paths = Vec::new();
    table_paths(table, &[], &mut paths);
    let keys: Vec<(usize, String)> = paths
        .iter()
        .enumerate()
        .flat_map(|(i, p)| keys_at(table, p).into_iter().map(move |k| (i, k)))
        .collect();
    if keys.is_empty() {
        return;
    }
    let (i, k) = &keys[key.index(keys.len())];
    if let Some(t) = table_at(table, &paths[*i]) {
        t.remove(k);
    }
}
