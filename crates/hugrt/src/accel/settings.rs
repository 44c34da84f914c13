//! Typed settings, and the one table per structure that reads them from a spec.
//!
//! Every structure has a settings type with [`Default`] (its defaults, written there and
//! nowhere else) and a typed constructor ([`super::Accel::with_settings`]); a spec string
//! `name:key=value,...` is only a way of filling one. The table ([`Settings::KEYS`]) gives each
//! key its field, the values it accepts and a line of help; from it come the spec's parsing,
//! the error that lists the valid keys, and the description `hugrt` prints
//! ([`Settings::describe`]), each key's default read from `Default` rather than written again.

use super::{Preset, Spec, SpecError};
use std::ops::RangeInclusive;

/// A value a settings key holds: how it is read from a spec, written back, and what it accepts.
pub trait Value: Sized {
    /// What restricts it: a range for numbers, nothing for flags and choices.
    type Range;
    /// The value written as `text`, or why it is not one.
    fn parse(text: &str, range: &Self::Range) -> Result<Self, String>;
    /// The value as a spec writes it.
    fn show(&self, range: &Self::Range) -> String;
    /// What `parse` accepts, e.g. `1..16` or `cubical|cube-root`.
    fn accepts(range: &Self::Range) -> String;
}

/// Numbers: parsed, then held to their range (which NaN, failing every comparison, never
/// meets).
macro_rules! number_value {
    ($ty:ty, $what:literal) => {
        impl Value for $ty {
            type Range = RangeInclusive<$ty>;
            fn parse(text: &str, range: &Self::Range) -> Result<Self, String> {
                let x: $ty = text.parse().map_err(|_| $what.to_string())?;
                if !(x >= *range.start() && x <= *range.end()) {
                    return Err(format!(
                        "must be between {} and {}",
                        range.start(),
                        range.end()
                    ));
                }
                Ok(x)
            }
            fn show(&self, _: &Self::Range) -> String {
                self.to_string()
            }
            fn accepts(range: &Self::Range) -> String {
                format!("{}..{}", range.start(), range.end())
            }
        }
    };
}

number_value!(usize, "not a whole number");
number_value!(f32, "not a number");

impl Value for bool {
    type Range = ();
    fn parse(text: &str, _: &()) -> Result<Self, String> {
        match text {
            "true" | "1" | "yes" | "on" => Ok(true),
            "false" | "0" | "no" | "off" => Ok(false),
            _ => Err("expected true or false".into()),
        }
    }
    fn show(&self, _: &Self::Range) -> String {
        self.to_string()
    }
    fn accepts(_: &()) -> String {
        "true|false".into()
    }
}

/// A number, or a word for "none": the structure chooses (`depth=auto`) or the feature is
/// off (`crowd=off`). The range is the number's and the word.
impl Value for Option<usize> {
    type Range = (RangeInclusive<usize>, &'static str);
    fn parse(text: &str, (range, word): &Self::Range) -> Result<Self, String> {
        if text == *word {
            return Ok(None);
        }
        usize::parse(text, range)
            .map(Some)
            .map_err(|e| format!("{e}, or {word}"))
    }
    fn show(&self, (_, word): &Self::Range) -> String {
        self.map_or_else(|| word.to_string(), |x| x.to_string())
    }
    fn accepts((range, word): &Self::Range) -> String {
        format!("{}|{word}", usize::accepts(range))
    }
}

/// Implements [`Value`] for a field-less enum whose variants are spelt as the given words.
macro_rules! choice_value {
    ($ty:ty { $($variant:path => $word:literal),+ $(,)? }) => {
        impl $crate::accel::settings::Value for $ty {
            type Range = ();
            fn parse(text: &str, _: &()) -> Result<Self, String> {
                match text {
                    $($word => Ok($variant),)+
                    _ => Err(format!("expected one of {}", [$($word),+].join(", "))),
                }
            }
            fn show(&self, _: &()) -> String {
                match self { $($variant => $word,)+ }.to_string()
            }
            fn accepts(_: &()) -> String {
                [$($word),+].join("|")
            }
        }
    };
}
pub(crate) use choice_value;

/// One key of a structure's spec.
pub struct Key<S: 'static> {
    pub name: &'static str,
    pub help: &'static str,
    /// What the key accepts ([`Value::accepts`]).
    pub accepts: fn() -> String,
    /// Sets the key's field from its text, or says why the text is not a value.
    pub set: fn(&mut S, &str) -> Result<(), String>,
    /// The key's field as a spec writes it.
    pub show: fn(&S) -> String,
}

/// A key of the table for field `$field` of type `$ty`, accepting what `$range` allows:
/// `key!("leaf", leaf: usize, 1..=16, "most primitives a leaf holds")`; `()` for flags and
/// choices.
macro_rules! key {
    ($name:literal, $field:ident: $ty:ty, $range:expr, $help:expr) => {
        $crate::accel::settings::Key {
            name: $name,
            help: $help,
            accepts: || <$ty as $crate::accel::settings::Value>::accepts(&$range),
            set: |s, text| {
                s.$field = <$ty as $crate::accel::settings::Value>::parse(text, &$range)?;
                Ok(())
            },
            show: |s| <$ty as $crate::accel::settings::Value>::show(&s.$field, &$range),
        }
    };
}
pub(crate) use key;

/// A key as `hugrt` describes it: what it accepts, its default, its help.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct KeyHelp {
    pub name: &'static str,
    pub accepts: String,
    pub default: String,
    pub help: &'static str,
}

/// The settings of one structure.
pub trait Settings: Default + Clone + std::fmt::Debug + Send + Sync + 'static {
    /// The table of keys.
    const KEYS: &'static [Key<Self>];
    /// The papers' algorithms this structure has as settings, reached by the key `preset`.
    const PRESETS: &'static [Preset] = &[];

    /// Checks what the settings cannot say alone (a choice that needs another key, say).
    fn validate(&self) -> Result<(), SpecError> {
        Ok(())
    }

    /// Every key's value within what the key accepts (the spec's parsing of the value written
    /// back), then [`Settings::validate`]: typed settings are held to the table's ranges.
    fn check(&self) -> Result<(), SpecError> {
        for key in Self::KEYS {
            let text = (key.show)(self);
            (key.set)(&mut self.clone(), &text).map_err(|reason| SpecError::BadValue {
                key: key.name.into(),
                value: text,
                reason,
            })?;
        }
        self.validate()
    }

    /// The settings a spec's keys give, starting from [`Default`] (and from its preset, if
    /// it names one: the other keys override the preset's).
    fn from_spec(spec: &Spec) -> Result<Self, SpecError> {
        let spec = spec.with_preset(Self::PRESETS)?;
        let mut s = Self::default();
        for (k, v) in &spec.params {
            let Some(key) = Self::KEYS.iter().find(|key| key.name == k) else {
                return Err(SpecError::UnknownKey {
                    name: spec.name.clone(),
                    key: k.clone(),
                    valid: Self::key_names(),
                });
            };
            (key.set)(&mut s, v).map_err(|reason| SpecError::BadValue {
                key: k.clone(),
                value: v.clone(),
                reason,
            })?;
        }
        s.validate()?;
        Ok(s)
    }

    /// The keys whose values differ from the defaults, as a spec writes them (empty for the
    /// defaults): `Settings::from_spec` of `name:` and this gives these settings back.
    fn to_spec_keys(&self) -> String {
        let d = Self::default();
        Self::KEYS
            .iter()
            .filter(|k| (k.show)(self) != (k.show)(&d))
            .map(|k| format!("{}={}", k.name, (k.show)(self)))
            .collect::<Vec<_>>()
            .join(",")
    }

    /// Every key with what it accepts, its default and its help (`preset` last, when the
    /// structure has presets).
    fn describe() -> Vec<KeyHelp> {
        let d = Self::default();
        let mut keys: Vec<KeyHelp> = Self::KEYS
            .iter()
            .map(|k| KeyHelp {
                name: k.name,
                accepts: (k.accepts)(),
                default: (k.show)(&d),
                help: k.help,
            })
            .collect();
        if !Self::PRESETS.is_empty() {
            keys.push(KeyHelp {
                name: "preset",
                accepts: Self::PRESETS
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join("|"),
                default: "none".into(),
                help: "the paper's algorithm, step for step (other keys given beside it override it)",
            });
        }
        keys
    }

    /// The valid keys, for errors.
    fn key_names() -> String {
        let names: Vec<&str> = Self::describe().iter().map(|k| k.name).collect();
        if names.is_empty() {
            "(none)".into()
        } else {
            names.join(", ")
        }
    }
}

/// The settings of a structure that has none (brute force).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoSettings;

impl Settings for NoSettings {
    const KEYS: &'static [Key<Self>] = &[];
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Shape {
        Round,
        Square,
    }
    choice_value!(Shape { Shape::Round => "round", Shape::Square => "square" });

    #[derive(Clone, Debug, PartialEq)]
    struct Toy {
        count: usize,
        scale: f32,
        on: bool,
        shape: Shape,
    }

    impl Default for Toy {
        fn default() -> Self {
            Toy {
                count: 4,
                scale: 0.5,
                on: true,
                shape: Shape::Round,
            }
        }
    }

    impl Settings for Toy {
        const KEYS: &'static [Key<Self>] = &[
            key!("count", count: usize, 1..=8, "how many"),
            key!("scale", scale: f32, 0.0..=1.0, "how large"),
            key!("on", on: bool, (), "whether"),
            key!("shape", shape: Shape, (), "which"),
        ];
        const PRESETS: &'static [Preset] = &[Preset {
            name: "paper",
            pairs: &[("count", "2", "§1"), ("shape", "square", "§2")],
        }];
    }

    fn toy(spec: &str) -> Result<Toy, SpecError> {
        Toy::from_spec(&Spec::parse(spec).unwrap())
    }

    #[test]
    fn the_table_reads_every_kind_of_value_and_says_what_is_wrong() {
        assert_eq!(toy("toy").unwrap(), Toy::default());
        let t = toy("toy:count=8,scale=0,on=false,shape=square").unwrap();
        assert_eq!(
            (t.count, t.scale, t.on, t.shape),
            (8, 0.0, false, Shape::Square)
        );
        let e = toy("toy:count=9").unwrap_err().to_string();
        assert!(e.contains("between 1 and 8"), "{e}");
        assert!(toy("toy:scale=nan").is_err());
        assert!(toy("toy:on=maybe").is_err());
        let e = toy("toy:shape=oval").unwrap_err().to_string();
        assert!(e.contains("round, square"), "{e}");
        let e = toy("toy:size=1").unwrap_err().to_string();
        assert!(e.contains("count, scale, on, shape, preset"), "{e}");
    }

    #[test]
    fn typed_settings_are_held_to_the_tables_ranges() {
        assert!(Toy::default().check().is_ok());
        let e = Toy {
            count: 0,
            ..Toy::default()
        }
        .check()
        .unwrap_err()
        .to_string();
        assert!(e.contains("count") && e.contains("between 1 and 8"), "{e}");
        let nan = Toy {
            scale: f32::NAN,
            ..Toy::default()
        };
        assert!(nan.check().is_err());
    }

    #[test]
    fn presets_are_overridden_and_settings_write_themselves_back() {
        let t = toy("toy:preset=paper,count=3").unwrap();
        assert_eq!((t.count, t.shape), (3, Shape::Square));
        assert_eq!(t.to_spec_keys(), "count=3,shape=square");
        assert_eq!(toy(&format!("toy:{}", t.to_spec_keys())).unwrap(), t);
        assert_eq!(Toy::default().to_spec_keys(), "");
        let d = Toy::describe();
        assert_eq!(d[0].accepts, "1..8");
        assert_eq!(d[0].default, "4");
        assert_eq!(d[3].accepts, "round|square");
        assert_eq!(d[4].name, "preset");
    }
}
