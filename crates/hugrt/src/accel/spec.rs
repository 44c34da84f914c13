//! Structure specs: `name[:key=value,...]`, e.g. `grid`, `grid:density=20,prune=true`.

use thiserror::Error;

#[derive(Debug, Error, PartialEq)]
pub enum SpecError {
    #[error("unknown structure '{name}'; valid structures: {valid}")]
    UnknownStructure { name: String, valid: String },
    #[error("structure '{name}' has no key '{key}'; valid keys: {valid}")]
    UnknownKey {
        name: String,
        key: String,
        valid: String,
    },
    #[error("malformed spec: {reason}")]
    Malformed { spec: String, reason: String },
    #[error("bad value '{value}' for key '{key}': {reason}")]
    BadValue {
        key: String,
        value: String,
        reason: String,
    },
    #[error("{0}")]
    Build(String),
}

/// A paper's algorithm as a structure's settings: key=value pairs, each with the section of
/// the paper that fixes it, reached by the structure's `preset` key.
#[derive(Clone, Copy, Debug)]
pub struct Preset {
    pub name: &'static str,
    /// `(key, value, where the paper says so)`.
    pub pairs: &'static [(&'static str, &'static str, &'static str)],
}

impl Preset {
    /// The preset as a spec's keys, e.g. `filter=levels,levels=3`.
    pub fn keys(&self) -> String {
        self.pairs
            .iter()
            .map(|(k, v, _)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(",")
    }
}

/// A parsed spec: the structure's name and its `key=value` pairs in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    pub name: String,
    pub params: Vec<(String, String)>,
}

impl Spec {
    pub fn parse(s: &str) -> Result<Spec, SpecError> {
        let malformed = |reason: &str| SpecError::Malformed {
            spec: s.to_string(),
            reason: reason.to_string(),
        };
        let (name, rest) = match s.split_once(':') {
            Some((n, r)) => (n.trim(), Some(r)),
            None => (s.trim(), None),
        };
        if name.is_empty() {
            return Err(malformed("empty structure name"));
        }
        let mut params = Vec::new();
        for kv in rest.into_iter().flat_map(|r| r.split(',')) {
            let (k, v) = kv
                .split_once('=')
                .ok_or_else(|| malformed(&format!("'{kv}' is not key=value")))?;
            let (k, v) = (k.trim(), v.trim());
            if k.is_empty() || v.is_empty() {
                return Err(malformed(&format!("'{kv}' is not key=value")));
            }
            if params.iter().any(|(pk, _): &(String, String)| pk == k) {
                return Err(malformed(&format!("key '{k}' given twice")));
            }
            params.push((k.to_string(), v.to_string()));
        }
        Ok(Spec {
            name: name.to_string(),
            params,
        })
    }

    fn raw(&self, key: &str) -> Option<&str> {
        self.params
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// This spec with a preset's pairs added for the keys it does not give itself: the value
    /// of `preset` names one of `presets`, and every other key given beside it overrides the
    /// preset's value. Without a `preset` key the spec is returned as it is.
    pub fn with_preset(&self, presets: &[Preset]) -> Result<Spec, SpecError> {
        let Some(name) = self.raw("preset") else {
            return Ok(self.clone());
        };
        let Some(p) = presets.iter().find(|p| p.name == name) else {
            return Err(SpecError::BadValue {
                key: "preset".into(),
                value: name.into(),
                reason: format!(
                    "expected one of {}",
                    presets
                        .iter()
                        .map(|p| p.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            });
        };
        let mut out = self.clone();
        out.params.retain(|(k, _)| k != "preset");
        for (k, v, _) in p.pairs {
            if self.raw(k).is_none() {
                out.params.push((k.to_string(), v.to_string()));
            }
        }
        Ok(out)
    }

    /// The raw value of a key, if given.
    pub fn value(&self, key: &str) -> Option<&str> {
        self.raw(key)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_names_and_pairs() {
        let s = Spec::parse("grid:density=20, prune=true").unwrap();
        assert_eq!(s.name, "grid");
        assert_eq!(s.value("density"), Some("20"));
        assert_eq!(s.value("prune"), Some("true"));
        assert!(Spec::parse("grid:density").is_err());
        assert!(Spec::parse(":x=1").is_err());
        assert!(Spec::parse("grid:a=1,a=2").is_err());
    }

    #[test]
    fn presets_fill_only_the_keys_not_given() {
        const P: &[Preset] = &[Preset {
            name: "paper",
            pairs: &[("a", "1", "§1"), ("b", "2", "§2")],
        }];
        let s = Spec::parse("x:preset=paper,b=5")
            .unwrap()
            .with_preset(P)
            .unwrap();
        assert_eq!(s.value("a"), Some("1"));
        assert_eq!(s.value("b"), Some("5"));
        assert_eq!(s.value("preset"), None);
        assert!(
            Spec::parse("x:preset=other")
                .unwrap()
                .with_preset(P)
                .is_err()
        );
        let plain = Spec::parse("x:a=3").unwrap();
        assert_eq!(plain.with_preset(P).unwrap(), plain);
    }
}
