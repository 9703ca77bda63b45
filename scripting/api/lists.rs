//! Comma lists from a simulator's text parameters (`--set samples=1,3`, `--set groups=A,C`):
//! each item read as its kind, and an empty item, one that does not read or one given twice
//! refused with the parameter's name and what to give — not Rhai's bare "cannot parse integer
//! from empty string", and not a sample run twice.

use super::{err, RhaiResult};
use crate::terminal_text::one_line;
use rhai::{Array, Dynamic, Engine, INT};

/// What a list's items are.
enum Kind {
    Int,
    /// Finite numbers.
    Float,
    /// One of these, whatever the case; given back as spelled here.
    Choice(Vec<String>),
}

impl Kind {
    fn of(kind: Dynamic) -> Result<Self, String> {
        if let Some(choices) = kind.clone().try_cast::<Array>() {
            let choices: Vec<String> = choices
                .into_iter()
                .map(|c| c.into_string().map_err(|t| format!("the choices are strings; got {t}")))
                .collect::<Result<_, _>>()?;
            if choices.is_empty() {
                return Err("give the choices, e.g. [\"A\", \"B\"]".into());
            }
            return Ok(Kind::Choice(choices));
        }
        match kind.into_string().as_deref() {
            Ok("int") => Ok(Kind::Int),
            Ok("float") => Ok(Kind::Float),
            _ => Err("the kind of the items is \"int\", \"float\" or an array of choices".into()),
        }
    }

    /// "a comma list of …", for the refusals.
    fn wanted(&self) -> String {
        match self {
            Kind::Int => "a comma list of integers, e.g. 1,3".into(),
            Kind::Float => "a comma list of numbers, e.g. 50,100.5".into(),
            Kind::Choice(c) => format!("a comma list of {}", c.join(", ")),
        }
    }

    /// One item as a value, and the key that says whether two items are the same.
    fn read(&self, item: &str) -> Option<(Dynamic, String)> {
        match self {
            Kind::Int => item.parse::<INT>().ok().map(|v| (Dynamic::from(v), v.to_string())),
            Kind::Float => {
                item.parse::<f64>().ok().filter(|v| v.is_finite()).map(|v| (Dynamic::from(v), (v + 0.0).to_string()))
            }
            Kind::Choice(c) => {
                c.iter().find(|a| a.eq_ignore_ascii_case(item)).map(|a| (Dynamic::from(a.clone()), a.clone()))
            }
        }
    }
}

/// The items of `text` read as `kind`, in order; `name` is the parameter, for the refusals.
fn items(text: &str, kind: &Kind, name: &str) -> Result<Array, String> {
    let wanted = kind.wanted();
    if text.trim().is_empty() {
        return Err(format!("{name} is empty; give {wanted}"));
    }
    let mut out = Array::new();
    let mut seen: Vec<String> = Vec::new();
    for item in text.split(',').map(str::trim) {
        if item.is_empty() {
            return Err(format!("{name}: an empty item in \"{text}\"; give {wanted}"));
        }
        let Some((value, key)) = kind.read(item) else {
            let what = match kind {
                Kind::Int => "an integer",
                Kind::Float => "a finite number",
                Kind::Choice(_) => "a choice",
            };
            return Err(format!("{name}: `{item}` is not {what}; give {wanted}"));
        };
        if seen.contains(&key) {
            return Err(format!("{name}: `{item}` is given twice; give each at most once, in {wanted}"));
        }
        seen.push(key);
        out.push(value);
    }
    Ok(out)
}

pub fn register(engine: &mut Engine) {
    let list = |text: &str, kind: Dynamic, name: &str| -> RhaiResult<Array> {
        // The text is a user's --set value and the name a script's: one line each in a message.
        let (text, name) = (one_line(text), one_line(name));
        let kind = Kind::of(kind).map_err(|e| err(format!("comma_list: {e}")))?;
        items(&text, &kind, &name).map_err(err)
    };
    engine
        .register_fn("comma_list", move |text: &str, kind: Dynamic, name: &str| list(text, kind, name))
        .register_fn("comma_list", move |text: &str, kind: Dynamic| list(text, kind, "comma_list"));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str, kind: Kind) -> Result<Vec<String>, String> {
        items(text, &kind, "samples").map(|a| a.into_iter().map(|v| v.to_string()).collect())
    }

    fn choices() -> Kind {
        Kind::Choice(vec!["A".into(), "B".into(), "C".into()])
    }

    #[test]
    fn items_are_read_as_their_kind_in_order() {
        assert_eq!(read(" 3, 1 ", Kind::Int).unwrap(), ["3", "1"]);
        assert_eq!(read("50,100.5,1e3", Kind::Float).unwrap(), ["50.0", "100.5", "1000.0"]);
        // A choice whatever the case, given back as the choice is spelled.
        assert_eq!(read("c,A", choices()).unwrap(), ["C", "A"]);
    }

    #[test]
    fn an_empty_unreadable_or_repeated_item_is_refused_naming_the_parameter() {
        let refused = |text: &str, kind: Kind| read(text, kind).unwrap_err();
        assert_eq!(refused(" ", Kind::Int), "samples is empty; give a comma list of integers, e.g. 1,3");
        assert!(refused("1,,3", Kind::Int).starts_with("samples: an empty item in \"1,,3\""));
        assert_eq!(
            refused("1,x", Kind::Int),
            "samples: `x` is not an integer; give a comma list of integers, e.g. 1,3"
        );
        assert!(refused("1.5", Kind::Int).starts_with("samples: `1.5` is not an integer"));
        assert!(refused("50,nan", Kind::Float).starts_with("samples: `nan` is not a finite number"));
        assert!(refused("inf", Kind::Float).starts_with("samples: `inf` is not a finite number"));
        assert_eq!(refused("A,Z", choices()), "samples: `Z` is not a choice; give a comma list of A, B, C");
        assert_eq!(
            refused("1,3,1", Kind::Int),
            "samples: `1` is given twice; give each at most once, in a comma list of integers, e.g. 1,3"
        );
        // The same value, however written; the same choice, whatever the case.
        assert!(refused("50,5e1", Kind::Float).starts_with("samples: `5e1` is given twice"));
        assert!(refused("0,-0", Kind::Float).starts_with("samples: `-0` is given twice"));
        assert!(refused("a,A", choices()).starts_with("samples: `A` is given twice"));
    }

    #[test]
    fn a_kind_that_is_not_one_is_refused() {
        assert!(Kind::of(Dynamic::from("integer")).is_err());
        assert!(Kind::of(Dynamic::from(Array::new())).is_err());
        assert!(Kind::of(Dynamic::from(vec![Dynamic::from(1_i64)])).is_err());
        assert!(matches!(Kind::of(Dynamic::from("float")), Ok(Kind::Float)));
    }
}
