//! Parameter tables: each setting's name, help, default and valid range declared once, in
//! the `params!` invocation that also declares its struct field. The command line (clap
//! arguments), the viewer (widgets), view files (validation) and `validate` all read the
//! table, so adding a setting is one entry.

use std::fmt;

/// Largest image side in pixels: the range of `--width` and `--height`, and what a render
/// piece's frame may declare.
pub const MAX_SIDE: u64 = 16384;

/// A value a parameter can hold, independent of its field's type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// On or off.
    Bool(bool),
    /// A whole number.
    Int(u64),
    /// A real number.
    Float(f32),
    /// One of a closed set of names.
    Choice(&'static str),
    /// An optional parameter that is not set.
    Unset,
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Bool(b) => f.write_str(if *b { "on" } else { "off" }),
            Value::Int(i) => write!(f, "{i}"),
            Value::Float(x) => write!(f, "{x}"),
            Value::Choice(c) => f.write_str(c),
            Value::Unset => f.write_str("off"),
        }
    }
}

/// One of a choice parameter's options: its name and what it means.
#[derive(Clone, Copy, Debug)]
pub struct Choice {
    /// Name on the command line and in view files.
    pub name: &'static str,
    /// One line of help.
    pub help: &'static str,
}

/// The values a parameter accepts.
#[derive(Clone, Copy, Debug)]
pub enum Domain {
    /// on or off.
    Switch,
    /// Whole numbers in min..=max; `optional` ones may also be unset ("off").
    Int {
        /// Smallest value.
        min: u64,
        /// Largest value.
        max: u64,
        /// Whether "off" (unset) is allowed.
        optional: bool,
    },
    /// Finite reals in min..=max; `optional` ones may also be unset ("off").
    Float {
        /// Smallest value.
        min: f32,
        /// Largest value.
        max: f32,
        /// Whether "off" (unset) is allowed.
        optional: bool,
    },
    /// One of these names.
    Choice(&'static [Choice]),
}

/// Where a parameter appears in the viewer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    /// The image's size.
    Image,
    /// The estimator and its sampling switches.
    Estimator,
    /// Numerical-robustness mechanisms.
    Robustness,
    /// Where pixels stop taking samples (the viewer's Convergence section).
    Convergence,
    /// The display transform.
    Display,
}

/// One parameter of a settings struct `T`.
pub struct Param<T: 'static> {
    /// Name on the command line (`--name`), in messages and (with `-` as `_`) in view files.
    pub name: &'static str,
    /// Short label for the viewer.
    pub label: &'static str,
    /// One line of help: the field's doc comment.
    pub help: &'static str,
    /// Viewer section.
    pub group: Group,
    /// Accepted values.
    pub domain: Domain,
    /// Whether the viewer shows it for these settings (e.g. only for the estimator it affects).
    pub shown: fn(&T) -> bool,
    /// The field's value.
    pub get: fn(&T) -> Value,
    /// Sets the field; false if the value has the wrong kind.
    pub set: fn(&mut T, Value) -> bool,
}

impl<T: Default> Param<T> {
    /// The default value.
    pub fn default_value(&self) -> Value {
        (self.get)(&T::default())
    }
}

impl<T> Param<T> {
    /// Parses a value as written on the command line; the error is one line without the name.
    pub fn parse(&self, text: &str) -> Result<Value, String> {
        let text = text.trim();
        let unset = |optional: bool| optional && matches!(text, "off" | "none");
        let value = match self.domain {
            Domain::Switch => match text {
                "on" | "true" | "yes" => Value::Bool(true),
                "off" | "false" | "no" => Value::Bool(false),
                _ => return Err(format!("'{text}' is not on or off")),
            },
            Domain::Int { optional, .. } if unset(optional) => Value::Unset,
            Domain::Int { .. } => match text.parse::<u64>() {
                Ok(i) => Value::Int(i),
                Err(_) if text.parse::<i128>().is_ok() || text.parse::<f64>().is_ok_and(f64::is_finite) => {
                    return Err(format!("{text} is not {}", self.range()));
                }
                Err(_) => return Err(format!("'{text}' is not a whole number")),
            },
            Domain::Float { optional, .. } if unset(optional) => Value::Unset,
            Domain::Float { .. } => match text.parse::<f32>() {
                Ok(x) => Value::Float(x),
                Err(_) => return Err(format!("'{text}' is not a number")),
            },
            Domain::Choice(options) => match options.iter().find(|c| c.name == text) {
                Some(c) => Value::Choice(c.name),
                None => return Err(format!("'{text}' is not {}", self.range())),
            },
        };
        self.check(value)?;
        Ok(value)
    }

    /// Checks that `value` lies in the domain; the error is one line without the name.
    pub fn check(&self, value: Value) -> Result<(), String> {
        let ok = match (self.domain, value) {
            (Domain::Switch, Value::Bool(_)) => true,
            (Domain::Int { optional, .. } | Domain::Float { optional, .. }, Value::Unset) => optional,
            (Domain::Int { min, max, .. }, Value::Int(i)) => (min..=max).contains(&i),
            (Domain::Float { min, max, .. }, Value::Float(x)) => x.is_finite() && (min..=max).contains(&x),
            (Domain::Choice(options), Value::Choice(c)) => options.iter().any(|o| o.name == c),
            _ => false,
        };
        if ok { Ok(()) } else { Err(format!("{value} is not {}", self.range())) }
    }

    /// The accepted values in words, e.g. "in 1..=64", "one of off, explicit, mis".
    pub fn range(&self) -> String {
        match self.domain {
            Domain::Switch => "on or off".into(),
            Domain::Int { min, max, optional } => {
                let range =
                    if max >= u32::MAX as u64 { format!("at least {min}") } else { format!("in {min}..={max}") };
                if optional { format!("{range} (or off)") } else { range }
            }
            Domain::Float { min, max, optional } => {
                let range = if max == f32::MAX {
                    format!("a finite number of at least {min}")
                } else {
                    format!("in {min}..={max}")
                };
                if optional { format!("{range} (or off)") } else { range }
            }
            Domain::Choice(options) => {
                let names: Vec<&str> = options.iter().map(|c| c.name).collect();
                format!("one of {}", names.join(", "))
            }
        }
    }
}

/// Checks every parameter of `table` on `settings`; the error names the first bad one.
pub fn validate<T>(table: &[Param<T>], settings: &T) -> Result<(), String> {
    for p in table {
        p.check((p.get)(settings)).map_err(|e| format!("{}: {e}", p.name))?;
    }
    Ok(())
}

/// A TOML error as one line, with the line and column (from 1, in characters) it was found at.
pub fn toml_error(text: &str, e: &toml::de::Error) -> String {
    let message = e.message().trim_end().replace('\n', " ");
    let Some(before) = e.span().and_then(|span| text.get(..span.start)) else { return message };
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!("line {line}, column {column}: {message}")
}

/// How a field's type maps to a `Value`.
pub trait ParamType: Sized {
    /// The field as a value.
    fn to_value(&self) -> Value;
    /// The field from a value of the right kind.
    fn from_value(v: Value) -> Option<Self>;
}

impl ParamType for bool {
    fn to_value(&self) -> Value {
        Value::Bool(*self)
    }
    fn from_value(v: Value) -> Option<Self> {
        if let Value::Bool(b) = v { Some(b) } else { None }
    }
}

impl ParamType for u32 {
    fn to_value(&self) -> Value {
        Value::Int(*self as u64)
    }
    fn from_value(v: Value) -> Option<Self> {
        if let Value::Int(i) = v { u32::try_from(i).ok() } else { None }
    }
}

impl ParamType for u64 {
    fn to_value(&self) -> Value {
        Value::Int(*self)
    }
    fn from_value(v: Value) -> Option<Self> {
        if let Value::Int(i) = v { Some(i) } else { None }
    }
}

impl ParamType for f32 {
    fn to_value(&self) -> Value {
        Value::Float(*self)
    }
    fn from_value(v: Value) -> Option<Self> {
        if let Value::Float(x) = v { Some(x) } else { None }
    }
}

impl<P: ParamType> ParamType for Option<P> {
    fn to_value(&self) -> Value {
        self.as_ref().map_or(Value::Unset, P::to_value)
    }
    fn from_value(v: Value) -> Option<Self> {
        if v == Value::Unset { Some(None) } else { P::from_value(v).map(Some) }
    }
}

/// Declares a fieldless enum of options from one list, each variant with its name and the
/// one line that is both its doc comment and its help in the parameter tables, and
/// implements `ParamType` for it: `choice_enum! { #[attrs] pub enum Type { #[default]
/// Variant = "name": "help", ... } }` also defines `Type::CHOICES` (in the variants'
/// order) and `Type::name`.
#[macro_export]
macro_rules! choice_enum {
    (
        $(#[$meta:meta])*
        pub enum $ty:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $name:literal: $help:literal ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
        #[serde(rename_all = "kebab-case")]
        pub enum $ty {
            $( #[doc = $help] $(#[$vmeta])* $variant ),+
        }

        impl $ty {
            /// The options, as the parameter tables list them.
            pub const CHOICES: &'static [$crate::params::Choice] =
                &[$($crate::params::Choice { name: $name, help: $help }),+];

            /// The name of this option.
            pub fn name(self) -> &'static str {
                match self { $(Self::$variant => $name),+ }
            }
        }

        impl $crate::params::ParamType for $ty {
            fn to_value(&self) -> $crate::params::Value {
                $crate::params::Value::Choice(self.name())
            }
            fn from_value(v: $crate::params::Value) -> Option<Self> {
                match v {
                    $($crate::params::Value::Choice($name) => Some(Self::$variant),)+
                    _ => None,
                }
            }
        }
    };
}

/// Declares a settings struct, its `Default` and its parameter table from one list:
/// each entry is the field's doc comment, `name: Type = default`, then
/// `[cli-name, "label", Group, domain, shown-when]`.
#[macro_export]
macro_rules! params {
    (
        $(#[$meta:meta])*
        pub struct $ty:ident, table $table:ident {
            $(
                #[doc = $doc:literal]
                $field:ident: $fty:ty = $default:expr,
                [$name:literal, $label:literal, $group:ident, $domain:expr, $shown:expr]
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        pub struct $ty {
            $(#[doc = $doc] pub $field: $fty,)*
        }

        impl Default for $ty {
            fn default() -> Self {
                Self { $($field: $default,)* }
            }
        }

        /// The parameter table of the struct above, in display order.
        pub static $table: &[$crate::params::Param<$ty>] = &[$(
            $crate::params::Param {
                name: $name,
                label: $label,
                help: $doc.trim_ascii(),
                group: $crate::params::Group::$group,
                domain: $domain,
                shown: $shown,
                get: |s: &$ty| $crate::params::ParamType::to_value(&s.$field),
                set: |s: &mut $ty, v| match <$fty as $crate::params::ParamType>::from_value(v) {
                    Some(x) => {
                        s.$field = x;
                        true
                    }
                    None => false,
                },
            },
        )*];
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    choice_enum! {
        /// A colour.
        pub enum Colour {
            #[default]
            Red = "red": "warm",
            Blue = "blue": "cold",
        }
    }

    params! {
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Demo, table DEMO {
            /// A count.
            count: u32 = 4, ["count", "count", Estimator, Domain::Int { min: 1, max: 64, optional: false }, |_| true],
            /// A limit.
            limit: Option<f32> = None, ["limit", "limit", Estimator, Domain::Float { min: 0.5, max: f32::MAX, optional: true }, |_| true],
            /// A colour.
            colour: Colour = Colour::Red, ["colour", "colour", Display, Domain::Choice(Colour::CHOICES), |d: &Demo| d.count > 1],
        }
    }

    #[test]
    fn one_entry_gives_field_default_parsing_and_range_checks() {
        let mut d = Demo::default();
        assert_eq!((d.count, d.limit, d.colour), (4, None, Colour::Red));
        assert_eq!(DEMO[0].help, "A count.");
        assert_eq!(DEMO[0].default_value(), Value::Int(4));
        assert_eq!(DEMO[0].parse("64"), Ok(Value::Int(64)));
        assert_eq!(DEMO[0].parse("65").unwrap_err(), "65 is not in 1..=64");
        assert_eq!(DEMO[0].parse("-3").unwrap_err(), "-3 is not in 1..=64");
        assert_eq!(DEMO[0].parse("x").unwrap_err(), "'x' is not a whole number");
        assert_eq!(DEMO[1].parse("off"), Ok(Value::Unset));
        assert!(DEMO[1].parse("0.1").unwrap_err().contains("at least 0.5"));
        assert!(DEMO[1].parse("inf").is_err(), "infinite values are refused");
        assert_eq!(DEMO[2].parse("green").unwrap_err(), "'green' is not one of red, blue");
        assert!((DEMO[2].set)(&mut d, DEMO[2].parse("blue").unwrap()));
        assert!((DEMO[1].set)(&mut d, Value::Float(2.0)));
        assert!(!(DEMO[0].set)(&mut d, Value::Bool(true)), "a value of the wrong kind is refused");
        assert_eq!((d.limit, d.colour), (Some(2.0), Colour::Blue));
        d.count = 0;
        assert_eq!(validate(DEMO, &d).unwrap_err(), "count: 0 is not in 1..=64");
        assert!(!(DEMO[2].shown)(&d));
    }
}
