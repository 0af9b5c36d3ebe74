//! A [`Snapshot`] as one HDF5 file (feature `hdf5`, through hdf5-metno).
//!
//! Layout (points and bonds in original order; 3-vectors as n × 3 datasets):
//!
//! | path | content |
//! |---|---|
//! | `/` attributes | `format_version`, `model_hash`, `solvers_hash`, `solver`, `step`, `time`, `history_step_duration`, `solver_rows`, `steps`, `broken_bonds` |
//! | `/points/*` | `displacement`, `velocity`, `acceleration`, `force_density`, `current_position`, `external_force_density` (with a body force) |
//! | `/bonds/family_size`, `/bonds/neighbor` | bonds per point, far end's original id per bond (`u32`) |
//! | `/bonds/damage` | bond damage (`f32`), with a damage model |
//! | `/history/<name>` | count × width, attributes `per_bond` and `width` |
//! | `/contact/*` | `points` (original ids, `u32`), `force_density`, `searched_at` (after the first search) |
//! | `/load_schedule/times` | attributes `next`, `total_cuts`, `accepted` (inside a quasi-static list) |
//! | `/monitor` | initial energy and supplied work (inside an explicit list) |
//! | `/outputs/*` | `calls`, `frames`, `rows`, one entry per deck `Output` list |

use super::{
    BondStructure, ContactSnapshot, HistoryField, LoadSchedule, OutputPosition, Position,
    RestartError, Snapshot, FORMAT_VERSION,
};
use hdf5::{Group, H5Type};
use std::path::Path;

fn failure(path: &Path) -> impl Fn(hdf5::Error) -> RestartError + '_ {
    move |error| RestartError::File {
        path: path.to_path_buf(),
        problem: error.to_string(),
    }
}

/// A dataset of `values`, `columns` numbers a row.
fn put<T: H5Type>(group: &Group, name: &str, values: &[T], columns: usize) -> hdf5::Result<()> {
    let rows = values.len() / columns.max(1);
    let dataset = group
        .new_dataset::<T>()
        .shape([rows, columns])
        .create(name)?;
    if !values.is_empty() {
        dataset.write_raw(values)?;
    }
    Ok(())
}

fn put_vectors(group: &Group, name: &str, values: &[[f64; 3]]) -> hdf5::Result<()> {
    put(group, name, values.as_flattened(), 3)
}

fn attr<T: H5Type>(group: &Group, name: &str, value: T) -> hdf5::Result<()> {
    group.new_attr::<T>().create(name)?.write_scalar(&value)
}

fn get<T: H5Type>(group: &Group, name: &str) -> hdf5::Result<Vec<T>> {
    group.dataset(name)?.read_raw()
}

fn get_vectors(group: &Group, name: &str) -> hdf5::Result<Vec<[f64; 3]>> {
    let flat: Vec<f64> = get(group, name)?;
    Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

fn get_attr<T: H5Type>(group: &Group, name: &str) -> hdf5::Result<T> {
    group.attr(name)?.read_scalar()
}

fn has(group: &Group, name: &str) -> bool {
    group.link_exists(name)
}

/// Writes `snapshot` to `path` (created or truncated).
pub fn write(path: &Path, snapshot: &Snapshot) -> Result<(), RestartError> {
    write_file(path, snapshot).map_err(failure(path))
}

fn write_file(path: &Path, s: &Snapshot) -> hdf5::Result<()> {
    let file = hdf5::File::create(path)?;
    attr(&file, "format_version", FORMAT_VERSION)?;
    attr(&file, "model_hash", s.model_hash)?;
    attr(&file, "solvers_hash", s.solvers_hash)?;
    attr(&file, "solver", s.position.solver as u64)?;
    attr(&file, "step", s.position.step)?;
    attr(&file, "time", s.time)?;
    attr(&file, "history_step_duration", s.history_step_duration)?;
    attr(&file, "solver_rows", s.solver_rows)?;
    attr(&file, "steps", s.steps)?;
    attr(&file, "broken_bonds", s.broken_bonds)?;

    let points = file.create_group("points")?;
    put_vectors(&points, "displacement", &s.displacement)?;
    put_vectors(&points, "velocity", &s.velocity)?;
    put_vectors(&points, "acceleration", &s.acceleration)?;
    put_vectors(&points, "force_density", &s.force_density)?;
    put_vectors(&points, "current_position", &s.current_position)?;
    if let Some(b) = &s.external_force_density {
        put_vectors(&points, "external_force_density", b)?;
    }
    let bonds = file.create_group("bonds")?;
    put(&bonds, "family_size", &s.bonds.family_size, 1)?;
    put(&bonds, "neighbor", &s.bonds.neighbor, 1)?;
    if let Some(damage) = &s.bond_damage {
        put(&bonds, "damage", damage, 1)?;
    }
    let history = file.create_group("history")?;
    // HDF5 lists a group's members by name; the declaration order is kept separately.
    attr(&history, "count", s.history.len() as u64)?;
    for (k, field) in s.history.iter().enumerate() {
        let group = history.create_group(&format!("{k}"))?;
        put(&group, "values", &field.values, field.width)?;
        attr(&group, "per_bond", u8::from(field.per_bond))?;
        attr(&group, "width", field.width as u64)?;
        let name: hdf5::types::VarLenUnicode = field
            .name
            .parse()
            .map_err(|e| hdf5::Error::from(format!("history field name: {e}")))?;
        group
            .new_attr::<hdf5::types::VarLenUnicode>()
            .create("name")?
            .write_scalar(&name)?;
    }
    if let Some(contact) = &s.contact {
        let group = file.create_group("contact")?;
        put(&group, "points", &contact.points, 1)?;
        put_vectors(&group, "force_density", &contact.force_density)?;
        if let Some(at) = &contact.searched_at {
            put_vectors(&group, "searched_at", at)?;
        }
    }
    if let Some(schedule) = &s.load_schedule {
        let group = file.create_group("load_schedule")?;
        put(&group, "times", &schedule.times, 1)?;
        attr(&group, "next", schedule.next as u64)?;
        attr(&group, "total_cuts", schedule.total_cuts)?;
        attr(&group, "accepted", schedule.accepted as u64)?;
    }
    if let Some(monitor) = &s.monitor {
        put(&file, "monitor", monitor, 1)?;
    }
    let outputs = file.create_group("outputs")?;
    let calls: Vec<i64> = s.outputs.iter().map(|o| o.calls).collect();
    let frames: Vec<u64> = s.outputs.iter().map(|o| o.frames).collect();
    let rows: Vec<u64> = s.outputs.iter().map(|o| o.rows).collect();
    attr(&outputs, "count", s.outputs.len() as u64)?;
    put(&outputs, "calls", &calls, 1)?;
    put(&outputs, "frames", &frames, 1)?;
    put(&outputs, "rows", &rows, 1)?;
    file.flush()?;
    Ok(())
}

/// Reads the snapshot at `path`.
pub fn read(path: &Path) -> Result<Snapshot, RestartError> {
    let snapshot = read_file(path).map_err(failure(path))?;
    Ok(snapshot)
}

fn read_file(path: &Path) -> hdf5::Result<Snapshot> {
    let file = hdf5::File::open(path)?;
    let version: u64 = get_attr(&file, "format_version")?;
    if version != FORMAT_VERSION {
        return Err(format!(
            "restart format version {version}; this peridyn reads version {FORMAT_VERSION}"
        )
        .into());
    }
    let points = file.group("points")?;
    let bonds = file.group("bonds")?;
    let history_group = file.group("history")?;
    let count: u64 = get_attr(&history_group, "count")?;
    let mut history = Vec::new();
    for k in 0..count {
        let group = history_group.group(&format!("{k}"))?;
        let name: hdf5::types::VarLenUnicode = get_attr(&group, "name")?;
        history.push(HistoryField {
            name: name.as_str().to_string(),
            per_bond: get_attr::<u8>(&group, "per_bond")? != 0,
            width: get_attr::<u64>(&group, "width")? as usize,
            values: get(&group, "values")?,
        });
    }
    let contact = if has(&file, "contact") {
        let group = file.group("contact")?;
        Some(ContactSnapshot {
            points: get(&group, "points")?,
            force_density: get_vectors(&group, "force_density")?,
            searched_at: if has(&group, "searched_at") {
                Some(get_vectors(&group, "searched_at")?)
            } else {
                None
            },
        })
    } else {
        None
    };
    let load_schedule = if has(&file, "load_schedule") {
        let group = file.group("load_schedule")?;
        Some(LoadSchedule {
            times: get(&group, "times")?,
            next: get_attr::<u64>(&group, "next")? as usize,
            total_cuts: get_attr(&group, "total_cuts")?,
            accepted: get_attr::<u64>(&group, "accepted")? as usize,
        })
    } else {
        None
    };
    let monitor = if has(&file, "monitor") {
        let values: Vec<f64> = get(&file, "monitor")?;
        match values[..] {
            [initial, work] => Some([initial, work]),
            _ => return Err("monitor: expected 2 values".into()),
        }
    } else {
        None
    };
    let outputs_group = file.group("outputs")?;
    let calls: Vec<i64> = get(&outputs_group, "calls")?;
    let frames: Vec<u64> = get(&outputs_group, "frames")?;
    let rows: Vec<u64> = get(&outputs_group, "rows")?;
    let outputs = calls
        .iter()
        .zip(&frames)
        .zip(&rows)
        .map(|((&calls, &frames), &rows)| OutputPosition {
            calls,
            frames,
            rows,
        })
        .collect();
    Ok(Snapshot {
        model_hash: get_attr(&file, "model_hash")?,
        solvers_hash: get_attr(&file, "solvers_hash")?,
        position: Position {
            solver: get_attr::<u64>(&file, "solver")? as usize,
            step: get_attr(&file, "step")?,
        },
        time: get_attr(&file, "time")?,
        displacement: get_vectors(&points, "displacement")?,
        velocity: get_vectors(&points, "velocity")?,
        acceleration: get_vectors(&points, "acceleration")?,
        force_density: get_vectors(&points, "force_density")?,
        current_position: get_vectors(&points, "current_position")?,
        bonds: BondStructure {
            family_size: get(&bonds, "family_size")?,
            neighbor: get(&bonds, "neighbor")?,
        },
        external_force_density: if has(&points, "external_force_density") {
            Some(get_vectors(&points, "external_force_density")?)
        } else {
            None
        },
        bond_damage: if has(&bonds, "damage") {
            Some(get(&bonds, "damage")?)
        } else {
            None
        },
        history,
        history_step_duration: get_attr(&file, "history_step_duration")?,
        contact,
        load_schedule,
        monitor,
        outputs,
        solver_rows: get_attr(&file, "solver_rows")?,
        steps: get_attr(&file, "steps")?,
        broken_bonds: get_attr(&file, "broken_bonds")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field survives the file bit for bit, including values whose last bit matters.
    #[test]
    fn a_snapshot_round_trips_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("restart.h5");
        let third = 1.0 / 3.0;
        let snapshot = Snapshot {
            model_hash: u64::MAX - 1,
            solvers_hash: 42,
            position: Position {
                solver: 1,
                step: 17,
            },
            time: 0.1 + 0.2,
            displacement: vec![[third, -0.0, f64::MIN_POSITIVE], [1e300, 2.0, 3.0]],
            velocity: vec![[1.0, 2.0, 3.0]; 2],
            acceleration: vec![[4.0, 5.0, 6.0]; 2],
            force_density: vec![[7.0, 8.0, 9.0]; 2],
            current_position: vec![[third; 3]; 2],
            bonds: BondStructure {
                family_size: vec![1, 1],
                neighbor: vec![1, 0],
            },
            external_force_density: Some(vec![[0.5; 3]; 2]),
            bond_damage: Some(vec![0.0, 1.0]),
            history: vec![HistoryField {
                name: "Deviatoric_Plastic_Extension".into(),
                per_bond: true,
                width: 1,
                values: vec![third, 0.25],
            }],
            history_step_duration: 1e-7,
            contact: Some(ContactSnapshot {
                points: vec![1],
                searched_at: Some(vec![[third; 3]]),
                force_density: vec![[1.5; 3]; 2],
            }),
            load_schedule: Some(LoadSchedule {
                times: vec![0.0, 0.5, 0.75, 1.0],
                next: 2,
                total_cuts: 1,
                accepted: 1,
            }),
            monitor: Some([third, 2.0]),
            outputs: vec![OutputPosition {
                calls: 18,
                frames: 4,
                rows: 4,
            }],
            solver_rows: 3,
            steps: 17,
            broken_bonds: 2,
        };
        write(&path, &snapshot).unwrap();
        assert_eq!(read(&path).unwrap(), snapshot);
    }

    #[test]
    fn a_file_that_is_not_hdf5_is_a_clear_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("restart.h5");
        std::fs::write(&path, "not HDF5").unwrap();
        let error = read(&path).unwrap_err().to_string();
        assert!(error.contains("restart.h5"), "{error}");
    }
}
