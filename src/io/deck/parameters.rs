//! Parameter trees handed on to a library as they are (NOX's list, Belos' sublist).

use super::tree::{Entry, NodeKind, ScalarKind};

/// A generic parameter tree (for lists handed on unchanged, such as NOX's).
#[derive(Debug, Clone, PartialEq)]
pub enum ParameterValue {
    /// A nested list, in file order.
    List(Vec<(String, ParameterValue)>),
    /// A string (an empty YAML value is an empty string).
    String(String),
    /// An integer.
    Int(i64),
    /// A double.
    Double(f64),
    /// A boolean.
    Bool(bool),
}

/// The deck entry `entry` (a list or a scalar) as a parameter tree.
pub(crate) fn to_parameter_value(entry: &Entry) -> ParameterValue {
    match &entry.value.kind {
        NodeKind::List(children) => ParameterValue::List(
            children
                .iter()
                .map(|c| (c.key.clone(), to_parameter_value(c)))
                .collect(),
        ),
        NodeKind::Scalar(s) => match s.kind {
            ScalarKind::String => ParameterValue::String(s.text.clone()),
            ScalarKind::Null => ParameterValue::String(String::new()),
            ScalarKind::Int(i) => ParameterValue::Int(i),
            ScalarKind::Double(d) => ParameterValue::Double(d),
            ScalarKind::Bool(b) => ParameterValue::Bool(b),
        },
    }
}
