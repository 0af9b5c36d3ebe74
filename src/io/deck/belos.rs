//! The `Belos` sublist of a `Solver` list: parameters handed to the Belos solver manager of
//! `Backend: "Trilinos"` as they are, after their names and types are checked here.
//!
//! peridyn sets Belos' `Block Size` (1), `Maximum Iterations` and `Convergence Tolerance` (from
//! `Linear Solver Maximum Iterations` / `Linear Solver Tolerance`, or Peridigm's `Belos *`
//! keys), the residual scalings (`Norm of RHS`), `Verbosity` (errors only) and BlockGMRES' `Num
//! Blocks`; a key in this sublist replaces peridyn's value. The names and types are those of
//! `getValidParameters()` of Belos' `BlockCGSolMgr` and `BlockGmresSolMgr` (Trilinos 13.2),
//! less `Output Stream`, which is a C++ stream.

use super::error::DeckError;
use super::parameters::ParameterValue;
use super::reader::{suggest, Ctx, Field};

/// The type Belos reads a parameter as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Int,
    Double,
    Bool,
    Text,
}

/// Which solver managers read a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ReadBy {
    Both,
    BlockCg,
    BlockGmres,
}

/// Every parameter the two solver managers accept (see the module docs).
const PARAMETERS: &[(&str, Kind, ReadBy)] = &[
    ("Convergence Tolerance", Kind::Double, ReadBy::Both),
    ("Maximum Iterations", Kind::Int, ReadBy::Both),
    ("Block Size", Kind::Int, ReadBy::Both),
    ("Adaptive Block Size", Kind::Bool, ReadBy::Both),
    ("Verbosity", Kind::Int, ReadBy::Both),
    ("Output Style", Kind::Int, ReadBy::Both),
    ("Output Frequency", Kind::Int, ReadBy::Both),
    ("Show Maximum Residual Norm Only", Kind::Bool, ReadBy::Both),
    ("Implicit Residual Scaling", Kind::Text, ReadBy::Both),
    ("Timer Label", Kind::Text, ReadBy::Both),
    ("Orthogonalization", Kind::Text, ReadBy::Both),
    ("Orthogonalization Constant", Kind::Double, ReadBy::Both),
    ("Use Single Reduction", Kind::Bool, ReadBy::BlockCg),
    ("Assert Positive Definiteness", Kind::Bool, ReadBy::BlockCg),
    ("Residual Norm", Kind::Text, ReadBy::BlockCg),
    (
        "Fold Convergence Detection Into Allreduce",
        Kind::Bool,
        ReadBy::BlockCg,
    ),
    ("Maximum Restarts", Kind::Int, ReadBy::BlockGmres),
    ("Num Blocks", Kind::Int, ReadBy::BlockGmres),
    ("Flexible Gmres", Kind::Bool, ReadBy::BlockGmres),
    ("Explicit Residual Test", Kind::Bool, ReadBy::BlockGmres),
    ("Explicit Residual Scaling", Kind::Text, ReadBy::BlockGmres),
];

/// Reads the `Belos` sublist `field` for a solve by BlockGMRES (`gmres`) or BlockCG. An
/// unknown name or a value of the wrong type is an error; a parameter only the other solver
/// manager reads is a warning (BlockCG hands over to BlockGMRES when it breaks down, which
/// then reads it). Integers are accepted for doubles and stored as doubles.
pub(crate) fn read(
    ctx: &mut Ctx,
    field: &Field,
    gmres: bool,
) -> Result<Vec<(String, ParameterValue)>, DeckError> {
    let mut list = field.list(ctx)?;
    let mut parameters = Vec::new();
    for entry in list.take_rest() {
        let name = entry.key();
        let Some(&(_, kind, read_by)) = PARAMETERS.iter().find(|(n, ..)| *n == name) else {
            let hint = match suggest(name, PARAMETERS.iter().map(|(n, ..)| *n)) {
                Some(s) => format!("did you mean \"{s}\"?"),
                None => format!(
                    "Belos BlockCG and BlockGMRES read {}",
                    PARAMETERS
                        .iter()
                        .map(|(n, ..)| format!("\"{n}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            };
            return Err(entry.err(ctx, format!("unknown Belos parameter; {hint}")));
        };
        let note = match (gmres, read_by) {
            (true, ReadBy::BlockCg) => {
                Some("only Belos BlockCG reads this parameter and this solver uses BlockGMRES; ignored")
            }
            (false, ReadBy::BlockGmres) => Some(
                "only Belos BlockGMRES reads this parameter; this solver uses BlockCG, which hands over to BlockGMRES when it breaks down",
            ),
            _ => None,
        };
        if let Some(note) = note {
            ctx.warn(entry.line(), &entry.path, note);
        }
        let value = match kind {
            Kind::Int => ParameterValue::Int(entry.i64(ctx)?),
            Kind::Double => ParameterValue::Double(entry.f64(ctx)?),
            Kind::Bool => ParameterValue::Bool(entry.bool(ctx)?),
            Kind::Text => ParameterValue::String(entry.name(ctx)?),
        };
        parameters.push((name.to_string(), value));
    }
    Ok(parameters)
}
