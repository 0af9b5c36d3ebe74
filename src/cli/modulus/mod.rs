//! `peridyn modulus`: Young's modulus from a tensile run's global outputs, as a tensile test
//! reads it (Littlewood, "Roadmap for Software Implementation", 2016, §18.8.2): a strain
//! gauge (two points whose positions and displacements are `Nearest_Point_Data` compute
//! classes) and a load cell (the reaction of a grip, a `Block_Data` sum of `Force`).
//!
//! For every loaded output frame of the run's `<Output Filename>.csv`, along the pulling axis:
//! * gauge length L₀ = y_top − y_bottom (initial positions),
//! * engineering strain ε = (u_top − u_bottom) / L₀,
//! * engineering stress σ = |F| / A (A the initial cross-section of the gauge section, given
//!   on the command line in the deck's length units squared),
//! * E = σ / |ε|, in the deck's stress units (dyne/cm² for CGS decks, Pa for SI).
//!
//! The unloaded frame (ε = 0 and F = 0, the initial state) is skipped; a frame with ε = 0
//! under load has no modulus and is an error.

pub mod glyphs;
pub mod history;
pub mod plot;

use std::path::PathBuf;

use history::History;

/// The pulling axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Axis {
    /// x.
    X,
    /// y (the axis of Peridigm's tensile_test example).
    Y,
    /// z.
    Z,
}

impl Axis {
    /// The component suffix of the CSV columns (`X`, `Y`, `Z`).
    fn suffix(self) -> &'static str {
        match self {
            Axis::X => "X",
            Axis::Y => "Y",
            Axis::Z => "Z",
        }
    }
}

/// Units of the deck, to quote E in GPa as well.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Units {
    /// CGS: stress in dyne/cm² (1 GPa = 1e10 dyne/cm²).
    Cgs,
    /// SI: stress in Pa (1 GPa = 1e9 Pa).
    Si,
}

impl Units {
    /// Stress units per GPa.
    fn per_gpa(self) -> f64 {
        match self {
            Units::Cgs => 1e10,
            Units::Si => 1e9,
        }
    }
}

/// The default globals of the load cell and the strain gauge: those `peridyn dogbone`'s deck
/// writes.
const FORCE_LABEL: &str = "Top_Reaction_Force";
const GAUGE_TOP_POSITION: &str = "Gage_Top_Initial_Position";
const GAUGE_BOTTOM_POSITION: &str = "Gage_Bottom_Initial_Position";
const GAUGE_TOP_DISPLACEMENT: &str = "Gage_Top_Displacement";
const GAUGE_BOTTOM_DISPLACEMENT: &str = "Gage_Bottom_Displacement";

/// Command-line options of `peridyn modulus`.
#[derive(Debug, Clone, clap::Args)]
pub struct ModulusArgs {
    /// The global-output CSV of a run (`<Output Filename>.csv`).
    pub csv: PathBuf,
    /// Initial cross-section of the gauge section (deck length units squared; 0.635 cm ×
    /// 0.315 cm = 0.2 cm² for `peridyn dogbone`'s specimen).
    #[arg(long)]
    pub area: f64,
    /// The load cell: a vector global whose component along the axis is the grip reaction.
    #[arg(long, default_value = FORCE_LABEL)]
    pub force_label: String,
    /// Initial position of the upper gauge point (a vector global).
    #[arg(long, default_value = GAUGE_TOP_POSITION)]
    pub gauge_top_position: String,
    /// Initial position of the lower gauge point.
    #[arg(long, default_value = GAUGE_BOTTOM_POSITION)]
    pub gauge_bottom_position: String,
    /// Displacement of the upper gauge point.
    #[arg(long, default_value = GAUGE_TOP_DISPLACEMENT)]
    pub gauge_top_displacement: String,
    /// Displacement of the lower gauge point.
    #[arg(long, default_value = GAUGE_BOTTOM_DISPLACEMENT)]
    pub gauge_bottom_displacement: String,
    /// The pulling axis.
    #[arg(long, value_enum, default_value = "y")]
    pub axis: Axis,
    /// The prescribed modulus, to print the secant E's deviation from it in %.
    #[arg(long)]
    pub expected: Option<f64>,
    /// The deck's units, to print E in GPa too.
    #[arg(long, value_enum)]
    pub units: Option<Units>,
    /// Write the stress–strain curve to this PNG file.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

impl ModulusArgs {
    /// The options with the default globals (see [`ModulusArgs::force_label`] and the gauge
    /// labels) for `csv`, of gauge section `area`, pulled along `axis`: no expected modulus,
    /// no units, no plot.
    pub fn with_default_labels(csv: PathBuf, area: f64, axis: Axis) -> Self {
        ModulusArgs {
            csv,
            area,
            force_label: FORCE_LABEL.into(),
            gauge_top_position: GAUGE_TOP_POSITION.into(),
            gauge_bottom_position: GAUGE_BOTTOM_POSITION.into(),
            gauge_top_displacement: GAUGE_TOP_DISPLACEMENT.into(),
            gauge_bottom_displacement: GAUGE_BOTTOM_DISPLACEMENT.into(),
            axis,
            expected: None,
            units: None,
            plot: None,
        }
    }
}

/// Why no modulus could be computed.
#[derive(Debug, thiserror::Error)]
pub enum ModulusError {
    /// The CSV cannot be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The CSV is malformed.
    #[error("{path}:{line}: {message}")]
    Syntax {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A label has no column.
    #[error("{path}: no column `{label}` (the file has: {available})")]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The column looked for.
        label: String,
        /// The columns the file has.
        available: String,
    },
    /// A command-line value or the data cannot give a modulus.
    #[error("{path}: {message}")]
    Data {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The plot cannot be drawn or written.
    #[error("{path}: cannot write the plot: {message}")]
    Plot {
        /// The PNG file.
        path: PathBuf,
        /// The drawing library's message.
        message: String,
    },
}

/// One loaded output frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Data row in the CSV (0 = the first frame, the initial state).
    pub frame: usize,
    /// Time of the frame.
    pub time: f64,
    /// Gauge length L₀ (length units).
    pub gauge_length: f64,
    /// Engineering strain ε = (u_top − u_bottom) / L₀.
    pub strain: f64,
    /// Engineering stress σ = |F| / A (stress units).
    pub stress: f64,
}

impl Sample {
    /// Secant modulus E = σ / |ε| (stress units; σ is a magnitude, so compression gives a
    /// positive E too).
    pub fn modulus(&self) -> f64 {
        self.stress / self.strain.abs()
    }
}

/// Column indices of the quantities a sample needs.
struct Columns {
    top_position: usize,
    bottom_position: usize,
    top_displacement: usize,
    bottom_displacement: usize,
    force: usize,
}

impl Columns {
    fn find(history: &History, args: &ModulusArgs) -> Result<Self, ModulusError> {
        let axis = args.axis.suffix();
        Ok(Self {
            top_position: history.column(&args.gauge_top_position, axis)?,
            bottom_position: history.column(&args.gauge_bottom_position, axis)?,
            top_displacement: history.column(&args.gauge_top_displacement, axis)?,
            bottom_displacement: history.column(&args.gauge_bottom_displacement, axis)?,
            force: history.column(&args.force_label, axis)?,
        })
    }
}

/// The loaded frames of `history`: strain, stress and gauge length per frame.
pub fn samples(history: &History, args: &ModulusArgs) -> Result<Vec<Sample>, ModulusError> {
    let data = |message: String| ModulusError::Data {
        path: history.path.clone(),
        message,
    };
    if !(args.area.is_finite() && args.area > 0.0) {
        return Err(data(format!(
            "--area {} must be a positive cross-section",
            args.area
        )));
    }
    let columns = Columns::find(history, args)?;
    let mut samples = Vec::new();
    for (frame, row) in history.rows.iter().enumerate() {
        let gauge_length = row[columns.top_position] - row[columns.bottom_position];
        if !(gauge_length.is_finite() && gauge_length > 0.0) {
            return Err(data(format!(
                "frame {frame} (time {}): gauge length {gauge_length} from {} − {} is not positive",
                row[0], args.gauge_top_position, args.gauge_bottom_position
            )));
        }
        let elongation = row[columns.top_displacement] - row[columns.bottom_displacement];
        let strain = elongation / gauge_length;
        let stress = row[columns.force].abs() / args.area;
        if strain == 0.0 && stress == 0.0 {
            continue;
        }
        if strain == 0.0 || !strain.is_finite() || !stress.is_finite() {
            return Err(data(format!(
                "frame {frame} (time {}): strain {strain} from {} and {} under stress {stress} from {}: no modulus",
                row[0], args.gauge_top_displacement, args.gauge_bottom_displacement, args.force_label
            )));
        }
        samples.push(Sample {
            frame,
            time: row[0],
            gauge_length,
            strain,
            stress,
        });
    }
    if samples.is_empty() {
        return Err(data(format!(
            "no loaded frame: {} and {} give zero strain in every row",
            args.gauge_top_displacement, args.gauge_bottom_displacement
        )));
    }
    Ok(samples)
}

/// The table `peridyn modulus` prints.
pub fn table(samples: &[Sample], args: &ModulusArgs) -> String {
    let mut text = format!(
        "{}: gauge {} − {} along {}, load {}{} over area {}\n",
        args.csv.display(),
        args.gauge_top_position,
        args.gauge_bottom_position,
        args.axis.suffix().to_lowercase(),
        args.force_label,
        args.axis.suffix(),
        args.area
    );
    text.push_str(&format!(
        "{:>5}  {:>12}  {:>12}  {:>13}  {:>13}  {:>13}",
        "frame", "time", "gauge length", "strain", "stress", "E"
    ));
    if args.units.is_some() {
        text.push_str(&format!("  {:>9}", "E [GPa]"));
    }
    if args.expected.is_some() {
        text.push_str(&format!("  {:>10}", "vs expected"));
    }
    text.push('\n');
    for sample in samples {
        let modulus = sample.modulus();
        text.push_str(&format!(
            "{:>5}  {:>12.6e}  {:>12.6e}  {:>13.6e}  {:>13.6e}  {:>13.6e}",
            sample.frame, sample.time, sample.gauge_length, sample.strain, sample.stress, modulus
        ));
        if let Some(units) = args.units {
            text.push_str(&format!("  {:>9.2}", modulus / units.per_gpa()));
        }
        if let Some(expected) = args.expected {
            text.push_str(&format!(
                "  {:>+9.2} %",
                100.0 * (modulus - expected) / expected
            ));
        }
        text.push('\n');
    }
    text
}

/// Reads the run's CSV, prints the table and writes the plot when asked.
pub fn main(args: &ModulusArgs) -> Result<String, ModulusError> {
    let history = History::read(&args.csv)?;
    let samples = samples(&history, args)?;
    if let Some(path) = &args.plot {
        plot::stress_strain(path, &samples, args.expected).map_err(|message| {
            ModulusError::Plot {
                path: path.clone(),
                message,
            }
        })?;
    }
    Ok(table(&samples, args))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn args(area: f64) -> ModulusArgs {
        ModulusArgs {
            expected: Some(2.0e12),
            units: Some(Units::Cgs),
            ..ModulusArgs::with_default_labels(PathBuf::from("run.csv"), area, Axis::Y)
        }
    }

    /// A bar of gauge length 2 (y = ±1) stretched by 0.1 % and 0.2 % under 4e8 and 8e8 dyne
    /// on 0.2 cm²: σ = 2e9 and 4e9, ε = 1e-3 and 2e-3, so E = 2e12 exactly in both frames.
    const KNOWN: &str =
        "Time,Gage_Top_Initial_PositionX,Gage_Top_Initial_PositionY,Gage_Top_Initial_PositionZ,\
Gage_Bottom_Initial_PositionX,Gage_Bottom_Initial_PositionY,Gage_Bottom_Initial_PositionZ,\
Gage_Top_DisplacementX,Gage_Top_DisplacementY,Gage_Top_DisplacementZ,\
Gage_Bottom_DisplacementX,Gage_Bottom_DisplacementY,Gage_Bottom_DisplacementZ,\
Top_Reaction_ForceX,Top_Reaction_ForceY,Top_Reaction_ForceZ
0.0,0,1,0,0,-1,0,0,0,0,0,0,0,0,0,0
0.5,0,1,0,0,-1,0,0,0.001,0,0,-0.001,0,0,-4e8,0
1.0,0,1,0,0,-1,0,0,0.002,0,0,-0.002,0,0,-8e8,0
";

    #[test]
    fn modulus_of_a_known_bar() {
        let history = History::parse(KNOWN, Path::new("run.csv")).unwrap();
        let samples = samples(&history, &args(0.2)).unwrap();
        assert_eq!(samples.len(), 2, "the unloaded frame is skipped");
        assert_eq!(samples[0].frame, 1);
        assert_eq!(samples[0].gauge_length, 2.0);
        assert!((samples[0].strain - 1e-3).abs() < 1e-15);
        assert!((samples[1].stress - 4e9).abs() < 1e-3);
        for sample in &samples {
            assert!((sample.modulus() / 2e12 - 1.0).abs() < 1e-12);
        }
        let table = table(&samples, &args(0.2));
        assert!(table.contains("2.000000e12"), "{table}");
        assert!(table.contains("200.00"), "{table}");
        assert!(table.contains("+0.00 %"), "{table}");
    }

    #[test]
    fn compression_gives_the_same_modulus() {
        let pulled = KNOWN.replace("0.001,0,0,-0.001", "-0.001,0,0,0.001");
        let history = History::parse(&pulled, Path::new("run.csv")).unwrap();
        let samples = samples(&history, &args(0.2)).unwrap();
        assert!(samples[0].strain < 0.0);
        assert!((samples[0].modulus() / 2e12 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn zero_strain_under_load_names_the_labels() {
        let text = KNOWN.replace("0,0,0.002,0,0,-0.002", "0,0,0,0,0,0");
        let history = History::parse(&text, Path::new("run.csv")).unwrap();
        let message = samples(&history, &args(0.2)).unwrap_err().to_string();
        assert!(
            message.contains("run.csv")
                && message.contains("frame 2")
                && message.contains("Gage_Top_Displacement"),
            "{message}"
        );
    }

    #[test]
    fn bad_area_and_unloaded_runs_are_errors() {
        let history = History::parse(KNOWN, Path::new("run.csv")).unwrap();
        let area = samples(&history, &args(0.0)).unwrap_err().to_string();
        assert!(area.contains("--area 0"), "{area}");
        let unloaded = History::parse(
            &KNOWN.lines().take(2).collect::<Vec<_>>().join("\n"),
            Path::new("run.csv"),
        )
        .unwrap();
        let message = samples(&unloaded, &args(0.2)).unwrap_err().to_string();
        assert!(message.contains("no loaded frame"), "{message}");
    }
}
