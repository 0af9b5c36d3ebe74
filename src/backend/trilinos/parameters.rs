//! Parameter trees ([`ParameterValue`]) as the flat, typed entries the C++ side turns
//! into a Teuchos `ParameterList` (NOX's and Belos' lists alike).

use super::ffi::bridge;
use crate::backend::parameters::ParameterValue;

/// A parameter tree as flat entries (sublist path, name, typed value), in tree order.
pub(super) fn flatten(tree: &[(String, ParameterValue)]) -> Vec<bridge::Parameter> {
    let mut out = Vec::new();
    flatten_into(tree, &mut Vec::new(), &mut out);
    out
}

fn flatten_into(
    tree: &[(String, ParameterValue)],
    path: &mut Vec<String>,
    out: &mut Vec<bridge::Parameter>,
) {
    use bridge::ParameterKind as Kind;
    for (name, value) in tree {
        let mut entry = bridge::Parameter {
            path: path.clone(),
            name: name.clone(),
            kind: Kind::Text,
            text: String::new(),
            number: 0.0,
            integer: 0,
            flag: false,
        };
        match value {
            ParameterValue::List(children) => {
                path.push(name.clone());
                flatten_into(children, path, out);
                path.pop();
                continue;
            }
            ParameterValue::String(s) => entry.text = s.clone(),
            ParameterValue::Double(d) => {
                entry.kind = Kind::Double;
                entry.number = *d;
            }
            // Teuchos stores these as `int`; a deck integer beyond its range is a deck error
            // Trilinos would reject anyway, so it saturates.
            ParameterValue::Int(i) => {
                entry.kind = Kind::Int;
                entry.integer = (*i).clamp(i32::MIN as i64, i32::MAX as i64) as i32;
            }
            ParameterValue::Bool(b) => {
                entry.kind = Kind::Bool;
                entry.flag = *b;
            }
        }
        out.push(entry);
    }
}
