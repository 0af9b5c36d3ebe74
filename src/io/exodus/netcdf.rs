//! A small, self-contained netCDF-3 reader and writer (classic `CDF\x01` and 64-bit offset
//! `CDF\x02` formats), enough for Exodus II files.
//!
//! Why our own instead of the `netcdf` crate (needs the C library) or the `netcdf3` crate: the
//! default build must not need a system C library, and the Exodus writer must leave a valid
//! file after every frame (record data written first, then `numrecs` in the header), which
//! needs control over exactly when the header count is written. The format is small: a
//! big-endian header (dimensions, attributes, variables with their file offsets), then the
//! fixed-size variables one after the other, then the records, each record holding one slab of
//! every record variable in header order. Every item is padded to 4 bytes.
//!
//! Reference: the "NetCDF Classic and 64-bit Offset File Formats" specification (Unidata).

use thiserror::Error;

mod header;
mod reader;
mod writer;

pub use reader::NcReader;
pub use writer::{encode, NcWriter};

/// What went wrong inside a netCDF-3 file (the Exodus layer adds the file name).
#[derive(Debug, Error)]
pub enum NcError {
    /// The operating system failed to read or write.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
    /// The first bytes are not `CDF\x01` or `CDF\x02`.
    #[error("not a netCDF-3 file (magic bytes {0:02x?}); netCDF-4/HDF5 and CDF-5 files are not supported, convert them with `nccopy -k 64-bit-offset`")]
    NotNetCdf(Vec<u8>),
    /// The header is inconsistent or ends early.
    #[error("malformed netCDF header: {0}")]
    BadHeader(String),
    /// The file is shorter than its header says.
    #[error("file is truncated: {0}")]
    Truncated(String),
    /// A variable the caller asked for does not exist.
    #[error("missing netCDF variable '{0}'")]
    MissingVariable(String),
    /// A variable exists but has an unexpected type or shape.
    #[error("netCDF variable '{name}': {problem}")]
    BadVariable {
        /// Variable name.
        name: String,
        /// What is wrong with it.
        problem: String,
    },
    /// Something to be written does not fit the format's limits.
    #[error("cannot write netCDF-3: {0}")]
    TooLarge(String),
}

/// The on-disk variant of netCDF-3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NcFormat {
    /// `CDF\x01`: 32-bit variable offsets.
    Classic,
    /// `CDF\x02`: 64-bit variable offsets (what Exodus and Peridigm write).
    Offset64,
}

/// The six netCDF-3 external types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NcType {
    /// Signed 8-bit integer.
    Byte,
    /// 8-bit character (text).
    Char,
    /// Signed 16-bit integer.
    Short,
    /// Signed 32-bit integer.
    Int,
    /// IEEE 754 single precision.
    Float,
    /// IEEE 754 double precision.
    Double,
}

impl NcType {
    fn from_code(code: u32) -> Result<Self, NcError> {
        Ok(match code {
            1 => NcType::Byte,
            2 => NcType::Char,
            3 => NcType::Short,
            4 => NcType::Int,
            5 => NcType::Float,
            6 => NcType::Double,
            other => {
                return Err(NcError::BadHeader(format!(
                    "unknown nc_type {other} (CDF-5 types are not supported)"
                )))
            }
        })
    }

    fn code(self) -> u32 {
        match self {
            NcType::Byte => 1,
            NcType::Char => 2,
            NcType::Short => 3,
            NcType::Int => 4,
            NcType::Float => 5,
            NcType::Double => 6,
        }
    }

    /// Bytes per value on disk.
    pub fn size(self) -> u64 {
        match self {
            NcType::Byte | NcType::Char => 1,
            NcType::Short => 2,
            NcType::Int | NcType::Float => 4,
            NcType::Double => 8,
        }
    }
}

/// A dimension; `len == 0` in the header marks the record (unlimited) dimension.
#[derive(Debug, Clone, PartialEq)]
pub struct Dimension {
    /// Dimension name.
    pub name: String,
    /// Length (0 for the record dimension).
    pub len: u64,
}

/// Attribute values by type.
#[derive(Debug, Clone, PartialEq)]
pub enum AttrValue {
    /// `NC_BYTE` values.
    Bytes(Vec<i8>),
    /// `NC_CHAR` text (raw bytes, usually ASCII).
    Text(Vec<u8>),
    /// `NC_SHORT` values.
    Shorts(Vec<i16>),
    /// `NC_INT` values.
    Ints(Vec<i32>),
    /// `NC_FLOAT` values.
    Floats(Vec<f32>),
    /// `NC_DOUBLE` values.
    Doubles(Vec<f64>),
}

impl AttrValue {
    /// The attribute as text, if it is `NC_CHAR` (trailing NULs removed).
    pub fn as_text(&self) -> Option<String> {
        match self {
            AttrValue::Text(bytes) => Some(text_from_bytes(bytes)),
            _ => None,
        }
    }
}

/// A named attribute.
#[derive(Debug, Clone, PartialEq)]
pub struct Attribute {
    /// Attribute name.
    pub name: String,
    /// Attribute values.
    pub value: AttrValue,
}

/// A variable as described in the header.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Variable name.
    pub name: String,
    /// Dimension indices, slowest first; a record variable has the record dimension first.
    pub dims: Vec<usize>,
    /// Variable attributes.
    pub attrs: Vec<Attribute>,
    /// External type.
    pub nc_type: NcType,
    /// File offset of the data (of record 0 for record variables).
    pub begin: u64,
}

/// A parsed (or to-be-written) netCDF-3 header.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// Classic or 64-bit offset.
    pub format: NcFormat,
    /// Number of records currently in the file.
    pub numrecs: u64,
    /// Dimensions in definition order.
    pub dims: Vec<Dimension>,
    /// Global attributes.
    pub attrs: Vec<Attribute>,
    /// Variables in definition order (which is also the on-disk order).
    pub vars: Vec<Variable>,
}

const NC_DIMENSION: u32 = 0x0A;
const NC_VARIABLE: u32 = 0x0B;
const NC_ATTRIBUTE: u32 = 0x0C;
/// `numrecs` value meaning "still being written, count from the file size".
const STREAMING: u32 = 0xFFFF_FFFF;

fn pad4(n: u64) -> u64 {
    n.div_ceil(4) * 4
}

/// Text from a fixed-width char field: up to the first NUL, trailing blanks removed.
pub fn text_from_bytes(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end])
        .trim_end()
        .to_string()
}

impl Header {
    /// Index of the record dimension, if any.
    pub fn record_dim(&self) -> Option<usize> {
        self.dims.iter().position(|d| d.len == 0)
    }

    /// Index of the dimension with this name.
    pub fn dim_index(&self, name: &str) -> Option<usize> {
        self.dims.iter().position(|d| d.name == name)
    }

    /// Length of the named dimension (the record count for the record dimension).
    pub fn dim_len(&self, name: &str) -> Option<u64> {
        self.dim_index(name).map(|i| {
            if self.dims[i].len == 0 {
                self.numrecs
            } else {
                self.dims[i].len
            }
        })
    }

    /// The variable with this name.
    pub fn var(&self, name: &str) -> Option<&Variable> {
        self.vars.iter().find(|v| v.name == name)
    }

    /// Global attribute by name.
    pub fn attr(&self, name: &str) -> Option<&AttrValue> {
        self.attrs.iter().find(|a| a.name == name).map(|a| &a.value)
    }

    /// Whether `var` runs along the record dimension.
    pub fn is_record_var(&self, var: &Variable) -> bool {
        match (var.dims.first(), self.record_dim()) {
            (Some(&first), Some(rec)) => first == rec,
            _ => false,
        }
    }

    /// Shape of one slab of `var`: all dimensions except the record dimension.
    pub fn slab_shape(&self, var: &Variable) -> Vec<u64> {
        let skip = usize::from(self.is_record_var(var));
        var.dims[skip..].iter().map(|&d| self.dims[d].len).collect()
    }

    /// Values in one slab (the whole variable for fixed-size variables, one record otherwise).
    pub fn slab_len(&self, var: &Variable) -> u64 {
        self.slab_shape(var).iter().product()
    }

    /// Padded on-disk size of one slab (`vsize` in the specification).
    fn vsize(&self, var: &Variable) -> u64 {
        pad4(self.slab_len(var) * var.nc_type.size())
    }

    /// Bytes per record: the sum of the record variables' `vsize`, except that a lone record
    /// variable is not padded (the specification's special case).
    pub fn record_size(&self) -> u64 {
        let rec: Vec<&Variable> = self.vars.iter().filter(|v| self.is_record_var(v)).collect();
        if rec.len() == 1 {
            self.slab_len(rec[0]) * rec[0].nc_type.size()
        } else {
            rec.iter().map(|v| self.vsize(v)).sum()
        }
    }

    /// Offset of the first record, or `None` without record variables.
    pub fn first_record_offset(&self) -> Option<u64> {
        self.vars
            .iter()
            .filter(|v| self.is_record_var(v))
            .map(|v| v.begin)
            .min()
    }
}

fn to_u32(value: u64, what: &str) -> Result<u32, NcError> {
    u32::try_from(value)
        .map_err(|_| NcError::TooLarge(format!("{what} {value} does not fit in 32 bits")))
}

/// Decodes big-endian values of `nc_type` to `f64` (integers convert exactly up to 2^53).
pub fn decode_f64(nc_type: NcType, raw: &[u8]) -> Vec<f64> {
    match nc_type {
        NcType::Byte | NcType::Char => raw.iter().map(|&b| f64::from(b as i8)).collect(),
        NcType::Short => raw
            .chunks_exact(2)
            .map(|c| f64::from(i16::from_be_bytes([c[0], c[1]])))
            .collect(),
        NcType::Int => raw
            .chunks_exact(4)
            .map(|c| f64::from(i32::from_be_bytes([c[0], c[1], c[2], c[3]])))
            .collect(),
        NcType::Float => raw
            .chunks_exact(4)
            .map(|c| f64::from(f32::from_be_bytes([c[0], c[1], c[2], c[3]])))
            .collect(),
        NcType::Double => raw
            .chunks_exact(8)
            .map(|c| f64::from_be_bytes(c.try_into().expect("8 bytes")))
            .collect(),
    }
}
