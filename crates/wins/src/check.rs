//! Problems found in settings, each under the dotted path of its key (`aoa.music.aoa_step_deg`),
//! all collected before they are reported together: a user fixing a file sees every mistake at
//! once, not one per run.

use std::fmt;

/// One setting that cannot be used.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Problem {
    /// Dotted path of the key (`window.max_frames`), or of the table for a problem between keys.
    pub key: String,
    /// What is wrong, and what would be right.
    pub message: String,
}

/// Every problem of a configuration (empty: usable).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Problems(pub Vec<Problem>);

impl Problems {
    /// No problem yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records a problem with `key` under `prefix` (empty: at the root).
    pub fn push(&mut self, prefix: &str, key: &str, message: impl Into<String>) {
        let key = if key.is_empty() {
            prefix.to_string()
        } else {
            join(prefix, key)
        };
        self.0.push(Problem {
            key,
            message: message.into(),
        });
    }

    /// Records `message` when `ok` is false.
    pub fn require(&mut self, ok: bool, prefix: &str, key: &str, message: impl Into<String>) {
        if !ok {
            self.push(prefix, key, message);
        }
    }

    /// `value` must be finite and in `[min, max]`.
    pub fn in_range(&mut self, prefix: &str, key: &str, value: f64, min: f64, max: f64) {
        let ok = value.is_finite() && (min..=max).contains(&value);
        self.require(
            ok,
            prefix,
            key,
            format!("{} is not in [{}, {}]", num(value), num(min), num(max)),
        );
    }

    /// `value` must be finite and `> 0`.
    pub fn positive(&mut self, prefix: &str, key: &str, value: f64) {
        let ok = value.is_finite() && value > 0.0;
        self.require(
            ok,
            prefix,
            key,
            format!("{} is not a finite value > 0", num(value)),
        );
    }

    /// `value` must be finite and `≥ 0`.
    pub fn non_negative(&mut self, prefix: &str, key: &str, value: f64) {
        let ok = value.is_finite() && value >= 0.0;
        self.require(
            ok,
            prefix,
            key,
            format!("{} is not a finite value ≥ 0", num(value)),
        );
    }

    /// `value` must be at least `min`.
    pub fn at_least(&mut self, prefix: &str, key: &str, value: usize, min: usize) {
        self.require(value >= min, prefix, key, format!("{value} is below {min}"));
    }

    /// The problems of another part, appended.
    pub fn extend(&mut self, other: Problems) {
        self.0.extend(other.0);
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// `Ok` when there is no problem.
    pub fn into_result(self) -> Result<(), Problems> {
        if self.is_empty() { Ok(()) } else { Err(self) }
    }
}

impl fmt::Display for Problems {
    /// One problem per line: `key: message`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, p) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            if p.key.is_empty() {
                write!(f, "{}", p.message)?;
            } else {
                write!(f, "{}: {}", p.key, p.message)?;
            }
        }
        Ok(())
    }
}

impl std::error::Error for Problems {}

/// A number as a reader expects it: `1e-9`, not `0.000000001`.
pub fn num(v: f64) -> String {
    let a = v.abs();
    if v != 0.0 && a.is_finite() && !(1e-3..1e6).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// `prefix.key`, or `key` at the root.
pub fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

/// A settings table laid over its defaults: every key of `user` that `defaults` has, with a value
/// of the same kind, replaces the default; every other key becomes a problem (an unknown key,
/// with the known key of the same name but another unit suggested; a value of the wrong kind).
/// An integer is taken where a float is expected. The result has every key of `defaults`, so it
/// deserializes whenever the kinds agree.
pub fn overlay(
    defaults: &toml::Table,
    user: &toml::Table,
    prefix: &str,
    problems: &mut Problems,
) -> toml::Table {
    let mut out = defaults.clone();
    for (key, value) in user {
        let path = join(prefix, key);
        let Some(default) = defaults.get(key) else {
            let hint = match (similar_key(defaults, key), nearest_key(defaults, key)) {
                (Some(k), _) => format!(" (did you mean `{k}`? units are part of the names)"),
                (None, Some(k)) => format!(" (did you mean `{k}`?)"),
                (None, None) => String::new(),
            };
            problems.push(prefix, key, format!("unknown key{hint}"));
            continue;
        };
        let taken = match (default, value) {
            (toml::Value::Table(d), toml::Value::Table(u)) => {
                Some(toml::Value::Table(overlay(d, u, &path, problems)))
            }
            (toml::Value::Float(_), toml::Value::Integer(i)) => Some(toml::Value::Float(*i as f64)),
            (d, u) if d.same_type(u) => Some(u.clone()),
            (d, u) => {
                problems.push(
                    prefix,
                    key,
                    format!("expected {}, found {} `{u}`", d.type_str(), u.type_str()),
                );
                None
            }
        };
        if let Some(v) = taken {
            out.insert(key.clone(), v);
        }
    }
    out
}

/// A known key with the same stem as `key` and another unit suffix (`gate_rad` → `gate_deg`).
fn similar_key<'a>(known: &'a toml::Table, key: &str) -> Option<&'a str> {
    let stem = |k: &'a str| k.rsplit_once('_').map_or(k, |(s, _)| s);
    let wanted = key.rsplit_once('_').map_or(key, |(s, _)| s);
    known.keys().map(String::as_str).find(|k| stem(k) == wanted)
}

/// The known key nearest to `key` when it is a slip of the keyboard: at most one edit in four
/// characters (two in `estimater` → `estimator`'s nine: insertions, deletions, substitutions).
fn nearest_key<'a>(known: &'a toml::Table, key: &str) -> Option<&'a str> {
    let allowed = key.chars().count().div_ceil(4).clamp(1, 3);
    known
        .keys()
        .map(|k| (edit_distance(k, key), k.as_str()))
        .filter(|(d, _)| *d <= allowed)
        .min()
        .map(|(_, k)| k)
}

/// Levenshtein distance between two strings, in characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// A deserializer's message split into the key it names (`… in `eval.align``, as `toml`
/// reports it) and the rest; the key is empty when the message names none.
pub(crate) fn located(error: &str) -> (String, String) {
    let error = error.trim();
    match error.rsplit_once("\nin `") {
        Some((message, key)) => (
            key.trim_end_matches('`').to_string(),
            message.trim().to_string(),
        ),
        None => (String::new(), error.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slip_of_the_keyboard_gets_the_key_it_meant() {
        let known: toml::Table = toml::from_str(
            "estimator = 1
window = 2
[eval]
align = 3
",
        )
        .unwrap();
        assert_eq!(nearest_key(&known, "estimater"), Some("estimator"));
        assert_eq!(nearest_key(&known, "windw"), Some("window"));
        assert_eq!(nearest_key(&known, "speed"), None);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        let mut p = Problems::new();
        overlay(
            &known,
            &toml::from_str("estimater = 1").unwrap(),
            "",
            &mut p,
        );
        assert_eq!(
            p.to_string(),
            "estimater: unknown key (did you mean `estimator`?)"
        );
        assert_eq!(
            located("unknown variant `foo`, expected `posyaw` or `se3`\nin `eval.align`\n"),
            (
                "eval.align".to_string(),
                "unknown variant `foo`, expected `posyaw` or `se3`".to_string()
            )
        );
        assert_eq!(located("no key here").0, "");
    }

    #[test]
    fn every_problem_is_kept_under_its_path() {
        let mut p = Problems::new();
        p.in_range("aoa", "step_deg", 1e-9, 0.05, 30.0);
        p.in_range("aoa", "width_deg", 20.0, 0.0, 90.0);
        p.positive("window", "sigma_m", f64::NAN);
        p.at_least("", "frames", 0, 1);
        p.require(false, "window", "", "limits cross");
        let keys: Vec<&str> = p.0.iter().map(|q| q.key.as_str()).collect();
        assert_eq!(keys, ["aoa.step_deg", "window.sigma_m", "frames", "window"]);
        let text = p.to_string();
        assert_eq!(text.lines().count(), 4, "{text}");
        assert!(
            text.starts_with("aoa.step_deg: 1e-9 is not in [0.05, 30]"),
            "{text}"
        );
        assert!(p.into_result().is_err());
        assert_eq!(Problems::new().into_result(), Ok(()));
    }

    #[test]
    fn overlay_takes_known_keys_and_lists_the_rest() {
        let defaults: toml::Table =
            toml::from_str("gate_deg = 5.0\nframes = 30\n[music]\nstep_deg = 1.0\nfb = true\n")
                .unwrap();
        let user: toml::Table = toml::from_str(
            "gate_rad = 0.1\nframes = \"thirty\"\nextra = 1\n[music]\nstep_deg = 2\nfb = 1\n",
        )
        .unwrap();
        let mut p = Problems::new();
        let out = overlay(&defaults, &user, "", &mut p);
        let keys: Vec<&str> = p.0.iter().map(|q| q.key.as_str()).collect();
        assert_eq!(keys, ["extra", "frames", "gate_rad", "music.fb"], "{p}");
        assert!(p.0[2].message.contains("did you mean `gate_deg`"), "{p}");
        assert!(
            p.0[1].message.contains("expected integer, found string"),
            "{p}"
        );
        // The integer 2 is taken as the float 2.0; refused values keep their defaults.
        assert_eq!(out["music"]["step_deg"].as_float(), Some(2.0));
        assert_eq!(out["frames"].as_integer(), Some(30));
        assert_eq!(out["gate_deg"].as_float(), Some(5.0));
    }
}
