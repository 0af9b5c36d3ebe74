//! The bond filters as decks give them (`Discretization → Bond Filters` and the `Bond Filters`
//! of the `Initial Damage` damage model): their geometry and its reader. The set-up turns them
//! into the filters of the neighbour search ([`crate::neighbors::BondFilter`]).

use std::path::PathBuf;

use crate::parameter_list::error::DeckError;
use crate::parameter_list::reader::{Ctx, Field, ListReader};

/// One entry of `Bond Filters` (also used by the `Initial Damage` damage model).
#[derive(Debug, Clone, PartialEq)]
pub struct BondFilter {
    /// The name of the filter's list.
    pub name: String,
    /// The filter's geometry.
    pub shape: BondFilterShape,
}

/// Geometry of a bond filter.
#[derive(Debug, Clone, PartialEq)]
pub enum BondFilterShape {
    /// `Type: "Rectangular_Plane"`: the rectangle with corner `Lower_Left_Corner_X/Y/Z`, edge
    /// `Bottom_Unit_Vector_X/Y/Z` × `Bottom_Length`, and the edge `normal × bottom` ×
    /// `Side_Length`.
    RectangularPlane {
        /// `Normal_X/Y/Z` (required, non-zero).
        normal: [f64; 3],
        /// `Lower_Left_Corner_X/Y/Z` (required).
        lower_left_corner: [f64; 3],
        /// `Bottom_Unit_Vector_X/Y/Z` (required, non-zero).
        bottom_unit_vector: [f64; 3],
        /// `Bottom_Length` (required, > 0).
        bottom_length: f64,
        /// `Side_Length` (required, > 0).
        side_length: f64,
    },
    /// `Type: "Disk"`: the disk with centre `Center_X/Y/Z`, normal `Normal_X/Y/Z`, `Radius`.
    Disk {
        /// `Center_X/Y/Z` (required).
        center: [f64; 3],
        /// `Normal_X/Y/Z` (required, non-zero).
        normal: [f64; 3],
        /// `Radius` (required, > 0).
        radius: f64,
    },
    /// `Type: "Exodus Mesh"`: every face (TRI3/QUAD4) of a shell mesh.
    ExodusMesh {
        /// `File Name` (required), resolved relative to the deck's directory.
        file_name: PathBuf,
    },
}

fn vector3(
    ctx: &Ctx,
    list: &mut ListReader,
    keys: [&'static str; 3],
    nonzero: bool,
) -> Result<[f64; 3], DeckError> {
    let v = [
        list.f64_req(ctx, keys[0])?,
        list.f64_req(ctx, keys[1])?,
        list.f64_req(ctx, keys[2])?,
    ];
    if nonzero && v.iter().all(|c| *c == 0.0) {
        let field = list.get(keys[0]).expect("just read");
        return Err(field.err(
            ctx,
            format!("`{}/{}/{}` must not all be zero", keys[0], keys[1], keys[2]),
        ));
    }
    Ok(v)
}

/// Reads one bond-filter list (`field` is the named entry under `Bond Filters`).
pub(crate) fn read_bond_filter(
    ctx: &mut Ctx,
    field: &Field,
    allowed: &[&'static str],
) -> Result<BondFilter, DeckError> {
    let mut list = field.list(ctx)?;
    let kind = list
        .require(ctx, "Type", "the filter type")?
        .choice(ctx, allowed)?;
    let rectangle_keys: &[&str] = &[
        "Lower_Left_Corner_X",
        "Lower_Left_Corner_Y",
        "Lower_Left_Corner_Z",
        "Bottom_Unit_Vector_X",
        "Bottom_Unit_Vector_Y",
        "Bottom_Unit_Vector_Z",
        "Bottom_Length",
        "Side_Length",
    ];
    let shape = match kind {
        "Rectangular_Plane" => BondFilterShape::RectangularPlane {
            normal: vector3(ctx, &mut list, ["Normal_X", "Normal_Y", "Normal_Z"], true)?,
            lower_left_corner: vector3(
                ctx,
                &mut list,
                [
                    "Lower_Left_Corner_X",
                    "Lower_Left_Corner_Y",
                    "Lower_Left_Corner_Z",
                ],
                false,
            )?,
            bottom_unit_vector: vector3(
                ctx,
                &mut list,
                [
                    "Bottom_Unit_Vector_X",
                    "Bottom_Unit_Vector_Y",
                    "Bottom_Unit_Vector_Z",
                ],
                true,
            )?,
            bottom_length: list.positive_req(ctx, "Bottom_Length")?,
            side_length: list.positive_req(ctx, "Side_Length")?,
        },
        "Disk" => BondFilterShape::Disk {
            center: vector3(ctx, &mut list, ["Center_X", "Center_Y", "Center_Z"], false)?,
            normal: vector3(ctx, &mut list, ["Normal_X", "Normal_Y", "Normal_Z"], true)?,
            radius: list.positive_req(ctx, "Radius")?,
        },
        "Exodus Mesh" => {
            let name = list.name_req(ctx, "File Name")?;
            BondFilterShape::ExodusMesh {
                file_name: ctx.resolve(&name),
            }
        }
        _ => unreachable!("choice() returns one of the allowed values"),
    };
    // Peridigm's own DiskFilter deck carries the rectangle keys on a Disk filter; the disk
    // filter never reads them.
    let ignored: Vec<(&str, &str)> = if kind == "Disk" {
        rectangle_keys
            .iter()
            .map(|k| (*k, "a Disk bond filter does not use rectangle parameters"))
            .collect()
    } else {
        Vec::new()
    };
    list.finish(ctx, &ignored)?;
    Ok(BondFilter {
        name: field.key().to_string(),
        shape,
    })
}
