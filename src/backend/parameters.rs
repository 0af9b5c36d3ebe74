//! Parameter trees handed to a library as they are: NOX's list, Belos' sublist. The deck
//! reader checks their syntax (and Belos' names and types); `crate::setup::solvers` copies
//! them here, where the backends read and complete them.

/// A typed parameter tree, as a Teuchos `ParameterList` holds one.
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

/// The parameter (or sublist) at `path` in the tree `tree`, `None` when a step is missing or
/// not a list.
pub fn value_at<'a>(
    tree: &'a [(String, ParameterValue)],
    path: &[&str],
) -> Option<&'a ParameterValue> {
    let (first, rest) = path.split_first()?;
    let (_, value) = tree.iter().find(|(k, _)| k == first)?;
    match (value, rest.is_empty()) {
        (value, true) => Some(value),
        (ParameterValue::List(children), false) => value_at(children, rest),
        _ => None,
    }
}

/// The string at `path` in `tree`, `None` when it is missing or not a string.
pub fn string_at<'a>(tree: &'a [(String, ParameterValue)], path: &[&str]) -> Option<&'a str> {
    match value_at(tree, path)? {
        ParameterValue::String(s) => Some(s),
        _ => None,
    }
}

/// Sets `name = value` in the sublist at `path` of `tree`, creating the sublists that are
/// missing (a later entry of the same name is replaced in place).
pub fn set_at(
    tree: &mut Vec<(String, ParameterValue)>,
    path: &[&str],
    (name, value): (&str, ParameterValue),
) {
    let Some((first, rest)) = path.split_first() else {
        match tree.iter_mut().find(|(k, _)| k == name) {
            Some((_, slot)) => *slot = value,
            None => tree.push((name.to_string(), value)),
        }
        return;
    };
    let index = match tree
        .iter()
        .position(|(k, v)| k == first && matches!(v, ParameterValue::List(_)))
    {
        Some(i) => i,
        None => {
            tree.push((first.to_string(), ParameterValue::List(Vec::new())));
            tree.len() - 1
        }
    };
    if let ParameterValue::List(children) = &mut tree[index].1 {
        set_at(children, rest, (name, value));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Direction → Newton → Linear Solver → Jacobian Operator: "Matrix-Free"`.
    fn tree() -> Vec<(String, ParameterValue)> {
        let mut tree = Vec::new();
        set_at(
            &mut tree,
            &["Direction", "Newton", "Linear Solver"],
            (
                "Jacobian Operator",
                ParameterValue::String("Matrix-Free".into()),
            ),
        );
        tree
    }

    #[test]
    fn lookups_follow_the_path() {
        let tree = tree();
        let path = ["Direction", "Newton", "Linear Solver", "Jacobian Operator"];
        assert_eq!(string_at(&tree, &path), Some("Matrix-Free"));
        assert_eq!(string_at(&tree, &["Direction", "Method"]), None);
        assert!(matches!(
            value_at(&tree, &["Direction", "Newton"]),
            Some(ParameterValue::List(_))
        ));
        // A scalar is not a list to walk through.
        assert_eq!(value_at(&tree, &[&path[..], &["x"]].concat()), None);
    }

    #[test]
    fn setting_replaces_in_place_and_creates_missing_lists() {
        let mut tree = tree();
        let path = ["Direction", "Newton", "Linear Solver"];
        set_at(
            &mut tree,
            &path,
            (
                "Jacobian Operator",
                ParameterValue::String("Have Jacobian".into()),
            ),
        );
        set_at(
            &mut tree,
            &["Printing"],
            ("Output Information", ParameterValue::Int(0)),
        );
        assert_eq!(
            string_at(&tree, &[&path[..], &["Jacobian Operator"]].concat()),
            Some("Have Jacobian")
        );
        assert_eq!(tree.len(), 2, "{tree:?}");
        assert_eq!(
            value_at(&tree, &["Printing", "Output Information"]),
            Some(&ParameterValue::Int(0))
        );
    }
}
