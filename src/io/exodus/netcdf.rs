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

use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};

use thiserror::Error;

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

    // ------------------------------------------------------------------------------------
    // Parsing
    // ------------------------------------------------------------------------------------

    /// Reads the header from the start of `file`; `file_len` resolves a streaming `numrecs`.
    pub fn read(file: &mut File, file_len: u64) -> Result<Header, NcError> {
        file.seek(SeekFrom::Start(0))?;
        let mut parser = HeaderParser {
            file,
            position: 0,
            file_len,
        };
        let magic = parser.bytes(4)?;
        let format = match magic.as_slice() {
            b"CDF\x01" => NcFormat::Classic,
            b"CDF\x02" => NcFormat::Offset64,
            _ => return Err(NcError::NotNetCdf(magic)),
        };
        let numrecs_raw = parser.u32()?;
        let dims = parser.dim_list()?;
        let attrs = parser.attr_list()?;
        let vars = parser.var_list(format, dims.len())?;
        let mut header = Header {
            format,
            numrecs: u64::from(numrecs_raw),
            dims,
            attrs,
            vars,
        };
        if header.dims.iter().filter(|d| d.len == 0).count() > 1 {
            return Err(NcError::BadHeader(
                "more than one unlimited dimension".to_string(),
            ));
        }
        if numrecs_raw == STREAMING {
            let recsize = header.record_size();
            header.numrecs = match header.first_record_offset() {
                Some(start) if recsize > 0 => file_len.saturating_sub(start) / recsize,
                _ => 0,
            };
        }
        Ok(header)
    }

    // ------------------------------------------------------------------------------------
    // Encoding
    // ------------------------------------------------------------------------------------

    /// Assigns `begin` to every variable (fixed variables right after the header, then the
    /// record variables) and returns the encoded header.
    pub fn layout(&mut self) -> Result<Vec<u8>, NcError> {
        // The header's length does not depend on the begin values (fixed-width fields), so
        // encode once to measure it, then fill in the offsets.
        let header_len = self.encode()?.len() as u64;
        let mut offset = header_len;
        let fixed: Vec<usize> = (0..self.vars.len())
            .filter(|&i| !self.is_record_var(&self.vars[i]))
            .collect();
        let records: Vec<usize> = (0..self.vars.len())
            .filter(|&i| self.is_record_var(&self.vars[i]))
            .collect();
        for i in fixed.into_iter().chain(records) {
            self.vars[i].begin = offset;
            offset += self.vsize(&self.vars[i]);
        }
        if self.format == NcFormat::Classic && offset > u64::from(u32::MAX) {
            return Err(NcError::TooLarge(
                "variable offsets exceed 4 GiB in the classic format".to_string(),
            ));
        }
        self.encode()
    }

    fn encode(&self) -> Result<Vec<u8>, NcError> {
        let mut out = Vec::new();
        out.extend_from_slice(match self.format {
            NcFormat::Classic => b"CDF\x01",
            NcFormat::Offset64 => b"CDF\x02",
        });
        put_u32(&mut out, to_u32(self.numrecs, "record count")?);
        if self.dims.is_empty() {
            out.extend_from_slice(&[0; 8]);
        } else {
            put_u32(&mut out, NC_DIMENSION);
            put_u32(&mut out, to_u32(self.dims.len() as u64, "dimension count")?);
            for dim in &self.dims {
                put_name(&mut out, &dim.name)?;
                put_u32(&mut out, to_u32(dim.len, "dimension length")?);
            }
        }
        put_attrs(&mut out, &self.attrs)?;
        if self.vars.is_empty() {
            out.extend_from_slice(&[0; 8]);
        } else {
            put_u32(&mut out, NC_VARIABLE);
            put_u32(&mut out, to_u32(self.vars.len() as u64, "variable count")?);
            for var in &self.vars {
                put_name(&mut out, &var.name)?;
                put_u32(&mut out, var.dims.len() as u32);
                for &d in &var.dims {
                    put_u32(&mut out, d as u32);
                }
                put_attrs(&mut out, &var.attrs)?;
                put_u32(&mut out, var.nc_type.code());
                // vsize is informational (readers recompute it); values that do not fit are
                // written as 2^32 - 1 as the specification allows for very large variables.
                let vsize = self.vsize(var);
                put_u32(&mut out, u32::try_from(vsize).unwrap_or(u32::MAX));
                match self.format {
                    NcFormat::Classic => put_u32(&mut out, to_u32(var.begin, "variable offset")?),
                    NcFormat::Offset64 => out.extend_from_slice(&var.begin.to_be_bytes()),
                }
            }
        }
        Ok(out)
    }
}

fn to_u32(value: u64, what: &str) -> Result<u32, NcError> {
    u32::try_from(value)
        .map_err(|_| NcError::TooLarge(format!("{what} {value} does not fit in 32 bits")))
}

fn put_u32(out: &mut Vec<u8>, value: u32) {
    out.extend_from_slice(&value.to_be_bytes());
}

fn put_padding(out: &mut Vec<u8>) {
    while out.len() % 4 != 0 {
        out.push(0);
    }
}

fn put_name(out: &mut Vec<u8>, name: &str) -> Result<(), NcError> {
    put_u32(out, to_u32(name.len() as u64, "name length")?);
    out.extend_from_slice(name.as_bytes());
    put_padding(out);
    Ok(())
}

fn put_attrs(out: &mut Vec<u8>, attrs: &[Attribute]) -> Result<(), NcError> {
    if attrs.is_empty() {
        out.extend_from_slice(&[0; 8]);
        return Ok(());
    }
    put_u32(out, NC_ATTRIBUTE);
    put_u32(out, attrs.len() as u32);
    for attr in attrs {
        put_name(out, &attr.name)?;
        let (nc_type, count) = match &attr.value {
            AttrValue::Bytes(v) => (NcType::Byte, v.len()),
            AttrValue::Text(v) => (NcType::Char, v.len()),
            AttrValue::Shorts(v) => (NcType::Short, v.len()),
            AttrValue::Ints(v) => (NcType::Int, v.len()),
            AttrValue::Floats(v) => (NcType::Float, v.len()),
            AttrValue::Doubles(v) => (NcType::Double, v.len()),
        };
        put_u32(out, nc_type.code());
        put_u32(out, to_u32(count as u64, "attribute length")?);
        match &attr.value {
            AttrValue::Bytes(v) => out.extend(v.iter().map(|&b| b as u8)),
            AttrValue::Text(v) => out.extend_from_slice(v),
            AttrValue::Shorts(v) => v.iter().for_each(|x| out.extend(x.to_be_bytes())),
            AttrValue::Ints(v) => v.iter().for_each(|x| out.extend(x.to_be_bytes())),
            AttrValue::Floats(v) => v.iter().for_each(|x| out.extend(x.to_be_bytes())),
            AttrValue::Doubles(v) => v.iter().for_each(|x| out.extend(x.to_be_bytes())),
        }
        put_padding(out);
    }
    Ok(())
}

struct HeaderParser<'a> {
    file: &'a mut File,
    position: u64,
    file_len: u64,
}

impl HeaderParser<'_> {
    fn bytes(&mut self, n: u64) -> Result<Vec<u8>, NcError> {
        if self.position + n > self.file_len {
            return Err(NcError::Truncated(format!(
                "header needs {n} bytes at offset {} but the file has {} bytes",
                self.position, self.file_len
            )));
        }
        let mut buf = vec![0u8; n as usize];
        self.file.read_exact(&mut buf)?;
        self.position += n;
        Ok(buf)
    }

    fn skip_padding(&mut self, n: u64) -> Result<(), NcError> {
        let pad = pad4(n) - n;
        if pad > 0 {
            self.bytes(pad)?;
        }
        Ok(())
    }

    fn u32(&mut self) -> Result<u32, NcError> {
        let b = self.bytes(4)?;
        Ok(u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self) -> Result<u64, NcError> {
        let b = self.bytes(8)?;
        Ok(u64::from_be_bytes(b.try_into().expect("8 bytes read")))
    }

    /// Count for a list that must fit into the rest of the file (each item ≥ `min_item` bytes),
    /// so that a corrupt count cannot make us allocate gigabytes.
    fn count(&mut self, min_item: u64, what: &str) -> Result<usize, NcError> {
        let n = u64::from(self.u32()?);
        if n * min_item > self.file_len.saturating_sub(self.position) {
            return Err(NcError::BadHeader(format!(
                "{what} count {n} is larger than the file can hold"
            )));
        }
        Ok(n as usize)
    }

    fn name(&mut self) -> Result<String, NcError> {
        let len = self.count(1, "name length")? as u64;
        let raw = self.bytes(len)?;
        self.skip_padding(len)?;
        String::from_utf8(raw).map_err(|_| NcError::BadHeader("name is not UTF-8".to_string()))
    }

    fn list_tag(&mut self, expected: u32, what: &str) -> Result<bool, NcError> {
        let tag = self.u32()?;
        if tag == 0 {
            let zero = self.u32()?;
            if zero != 0 {
                return Err(NcError::BadHeader(format!("absent {what} list not zero")));
            }
            return Ok(false);
        }
        if tag != expected {
            return Err(NcError::BadHeader(format!(
                "expected {what} list tag {expected:#x}, found {tag:#x}"
            )));
        }
        Ok(true)
    }

    fn dim_list(&mut self) -> Result<Vec<Dimension>, NcError> {
        if !self.list_tag(NC_DIMENSION, "dimension")? {
            return Ok(Vec::new());
        }
        let n = self.count(8, "dimension")?;
        (0..n)
            .map(|_| {
                let name = self.name()?;
                let len = u64::from(self.u32()?);
                Ok(Dimension { name, len })
            })
            .collect()
    }

    fn attr_list(&mut self) -> Result<Vec<Attribute>, NcError> {
        if !self.list_tag(NC_ATTRIBUTE, "attribute")? {
            return Ok(Vec::new());
        }
        let n = self.count(12, "attribute")?;
        let mut attrs = Vec::with_capacity(n);
        for _ in 0..n {
            let name = self.name()?;
            let nc_type = NcType::from_code(self.u32()?)?;
            let count = self.count(nc_type.size(), "attribute value")? as u64;
            let raw = self.bytes(count * nc_type.size())?;
            self.skip_padding(count * nc_type.size())?;
            let value = match nc_type {
                NcType::Byte => AttrValue::Bytes(raw.iter().map(|&b| b as i8).collect()),
                NcType::Char => AttrValue::Text(raw),
                NcType::Short => AttrValue::Shorts(
                    raw.chunks_exact(2)
                        .map(|c| i16::from_be_bytes([c[0], c[1]]))
                        .collect(),
                ),
                NcType::Int => AttrValue::Ints(
                    raw.chunks_exact(4)
                        .map(|c| i32::from_be_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                ),
                NcType::Float => AttrValue::Floats(
                    raw.chunks_exact(4)
                        .map(|c| f32::from_be_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                ),
                NcType::Double => AttrValue::Doubles(
                    raw.chunks_exact(8)
                        .map(|c| f64::from_be_bytes(c.try_into().expect("8 bytes")))
                        .collect(),
                ),
            };
            attrs.push(Attribute { name, value });
        }
        Ok(attrs)
    }

    fn var_list(&mut self, format: NcFormat, n_dims: usize) -> Result<Vec<Variable>, NcError> {
        if !self.list_tag(NC_VARIABLE, "variable")? {
            return Ok(Vec::new());
        }
        let n = self.count(24, "variable")?;
        let mut vars = Vec::with_capacity(n);
        for _ in 0..n {
            let name = self.name()?;
            let rank = self.count(4, "dimension id")?;
            let mut dims = Vec::with_capacity(rank);
            for _ in 0..rank {
                let d = self.u32()? as usize;
                if d >= n_dims {
                    return Err(NcError::BadHeader(format!(
                        "variable '{name}' uses dimension id {d} but only {n_dims} exist"
                    )));
                }
                dims.push(d);
            }
            let attrs = self.attr_list()?;
            let nc_type = NcType::from_code(self.u32()?)?;
            let _vsize = self.u32()?;
            let begin = match format {
                NcFormat::Classic => u64::from(self.u32()?),
                NcFormat::Offset64 => self.u64()?,
            };
            vars.push(Variable {
                name,
                dims,
                attrs,
                nc_type,
                begin,
            });
        }
        Ok(vars)
    }
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

/// An open netCDF-3 file for reading.
#[derive(Debug)]
pub struct NcReader {
    file: File,
    file_len: u64,
    /// The parsed header.
    pub header: Header,
}

impl NcReader {
    /// Opens and parses the header; checks that the file holds all fixed-size data and
    /// `numrecs` complete records.
    pub fn open(mut file: File) -> Result<Self, NcError> {
        let file_len = file.metadata()?.len();
        let header = Header::read(&mut file, file_len)?;
        let reader = NcReader {
            file,
            file_len,
            header,
        };
        for var in &reader.header.vars {
            if !reader.header.is_record_var(var) {
                let end = var.begin + reader.header.slab_len(var) * var.nc_type.size();
                if end > file_len {
                    return Err(NcError::Truncated(format!(
                        "variable '{}' needs bytes up to {end} but the file has {file_len}",
                        var.name
                    )));
                }
            }
        }
        if let Some(start) = reader.header.first_record_offset() {
            let needed = reader
                .header
                .numrecs
                .saturating_mul(reader.header.record_size())
                .saturating_add(start);
            // The last record may legitimately end without padding, so compare only the data.
            if reader.header.numrecs > 0 && needed > file_len + 3 {
                let complete = file_len.saturating_sub(start) / reader.header.record_size().max(1);
                return Err(NcError::Truncated(format!(
                    "the header announces {} records but the file holds only {complete} complete ones",
                    reader.header.numrecs
                )));
            }
        }
        Ok(reader)
    }

    /// The named variable, or [`NcError::MissingVariable`].
    pub fn var(&self, name: &str) -> Result<&Variable, NcError> {
        self.header
            .var(name)
            .ok_or_else(|| NcError::MissingVariable(name.to_string()))
    }

    fn read_at(&self, offset: u64, len: u64, what: &str) -> Result<Vec<u8>, NcError> {
        if offset + len > self.file_len {
            return Err(NcError::Truncated(format!(
                "{what} needs bytes {offset}..{} but the file has {}",
                offset + len,
                self.file_len
            )));
        }
        let mut buf = vec![0u8; len as usize];
        let mut file = &self.file;
        file.seek(SeekFrom::Start(offset))?;
        file.read_exact(&mut buf)?;
        Ok(buf)
    }

    /// Raw bytes of a fixed-size variable, or of one record of a record variable.
    pub fn raw(&self, name: &str, record: Option<usize>) -> Result<(NcType, Vec<u8>), NcError> {
        let var = self.var(name)?;
        let len = self.header.slab_len(var) * var.nc_type.size();
        let offset = match (self.header.is_record_var(var), record) {
            (false, None) => var.begin,
            (true, Some(r)) => {
                if r as u64 >= self.header.numrecs {
                    return Err(NcError::BadVariable {
                        name: name.to_string(),
                        problem: format!(
                            "record {r} requested but the file has {} records",
                            self.header.numrecs
                        ),
                    });
                }
                var.begin + r as u64 * self.header.record_size()
            }
            (false, Some(_)) => {
                return Err(NcError::BadVariable {
                    name: name.to_string(),
                    problem: "is not a record variable".to_string(),
                })
            }
            (true, None) => {
                return Err(NcError::BadVariable {
                    name: name.to_string(),
                    problem: "is a record variable; a record index is needed".to_string(),
                })
            }
        };
        Ok((var.nc_type, self.read_at(offset, len, name)?))
    }

    /// Numeric variable (or one record of it) converted to `f64`.
    pub fn f64s(&self, name: &str, record: Option<usize>) -> Result<Vec<f64>, NcError> {
        let (nc_type, raw) = self.raw(name, record)?;
        if nc_type == NcType::Char {
            return Err(NcError::BadVariable {
                name: name.to_string(),
                problem: "is text, expected numbers".to_string(),
            });
        }
        Ok(decode_f64(nc_type, &raw))
    }

    /// Integer variable as `i64` (floating values are rejected).
    pub fn i64s(&self, name: &str) -> Result<Vec<i64>, NcError> {
        let (nc_type, raw) = self.raw(name, None)?;
        match nc_type {
            NcType::Byte | NcType::Short | NcType::Int => Ok(decode_f64(nc_type, &raw)
                .into_iter()
                .map(|x| x as i64)
                .collect()),
            _ => Err(NcError::BadVariable {
                name: name.to_string(),
                problem: format!("has type {nc_type:?}, expected integers"),
            }),
        }
    }

    /// A 2-D char variable as a list of strings (one per row).
    pub fn strings(&self, name: &str) -> Result<Vec<String>, NcError> {
        let var = self.var(name)?;
        let shape = self.header.slab_shape(var);
        if var.nc_type != NcType::Char || shape.len() != 2 {
            return Err(NcError::BadVariable {
                name: name.to_string(),
                problem: "expected a 2-D char array of names".to_string(),
            });
        }
        let (_, raw) = self.raw(name, None)?;
        let width = shape[1] as usize;
        if width == 0 {
            return Ok(vec![String::new(); shape[0] as usize]);
        }
        Ok(raw.chunks(width).map(text_from_bytes).collect())
    }
}

/// Writes a netCDF-3 file: header and fixed data up front, then records appended one by one,
/// each followed by an update of `numrecs` so that the file is complete after every record.
#[derive(Debug)]
pub struct NcWriter {
    file: File,
    header: Header,
    record_size: u64,
    first_record: u64,
}

impl NcWriter {
    /// Lays out `header` (assigning offsets), writes it and zero-fills the fixed-size data.
    pub fn create(mut file: File, mut header: Header) -> Result<Self, NcError> {
        header.numrecs = 0;
        let encoded = header.layout()?;
        file.write_all(&encoded)?;
        let mut end = encoded.len() as u64;
        for var in header.vars.iter().filter(|v| !header.is_record_var(v)) {
            end = end.max(var.begin + header.vsize(var));
        }
        file.set_len(end)?;
        let record_size = header.record_size();
        let first_record = header.first_record_offset().unwrap_or(end);
        if header
            .vars
            .iter()
            .any(|v| header.is_record_var(v) && header.vsize(v) > u64::from(u32::MAX))
        {
            return Err(NcError::TooLarge(
                "a record variable slab exceeds 4 GiB".to_string(),
            ));
        }
        Ok(NcWriter {
            file,
            header,
            record_size,
            first_record,
        })
    }

    /// The laid-out header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Writes the encoded (big-endian, unpadded) values of a fixed-size variable.
    pub fn put_fixed(&mut self, name: &str, data: &[u8]) -> Result<(), NcError> {
        let var = self
            .header
            .var(name)
            .ok_or_else(|| NcError::MissingVariable(name.to_string()))?;
        let expected = self.header.slab_len(var) * var.nc_type.size();
        if self.header.is_record_var(var) || data.len() as u64 != expected {
            return Err(NcError::BadVariable {
                name: name.to_string(),
                problem: format!(
                    "expected {expected} bytes of fixed data, got {}",
                    data.len()
                ),
            });
        }
        self.file.seek(SeekFrom::Start(var.begin))?;
        self.file.write_all(data)?;
        Ok(())
    }

    /// Appends one record. `slabs` holds the encoded slab of every record variable in header
    /// order. The data is written first and `numrecs` afterwards, so a crash between the two
    /// leaves the previous, complete state.
    pub fn append_record(&mut self, slabs: &[Vec<u8>]) -> Result<(), NcError> {
        let record_vars: Vec<&Variable> = self
            .header
            .vars
            .iter()
            .filter(|v| self.header.is_record_var(v))
            .collect();
        if slabs.len() != record_vars.len() {
            return Err(NcError::BadVariable {
                name: "<record>".to_string(),
                problem: format!(
                    "{} record slabs given for {} record variables",
                    slabs.len(),
                    record_vars.len()
                ),
            });
        }
        for (var, slab) in record_vars.iter().zip(slabs) {
            let expected = self.header.slab_len(var) * var.nc_type.size();
            if slab.len() as u64 != expected {
                return Err(NcError::BadVariable {
                    name: var.name.clone(),
                    problem: format!("expected {expected} bytes per record, got {}", slab.len()),
                });
            }
        }
        // Record variables are contiguous inside a record, each padded to its vsize (except a
        // lone record variable), so the slabs can be streamed one after the other.
        let offset = self.first_record + self.header.numrecs * self.record_size;
        self.file.seek(SeekFrom::Start(offset))?;
        let mut out = std::io::BufWriter::new(&mut self.file);
        let mut written = 0u64;
        for slab in slabs {
            out.write_all(slab)?;
            let padded = pad4(slab.len() as u64);
            let pad =
                (padded - slab.len() as u64).min(self.record_size - written - slab.len() as u64);
            out.write_all(&[0u8; 3][..pad as usize])?;
            written += slab.len() as u64 + pad;
        }
        out.flush()?;
        drop(out);
        debug_assert_eq!(written, self.record_size);
        self.header.numrecs += 1;
        self.file.seek(SeekFrom::Start(4))?;
        self.file
            .write_all(&to_u32(self.header.numrecs, "record count")?.to_be_bytes())?;
        self.file.flush()?;
        Ok(())
    }

    /// Takes over the first `count` records of `previous`, a file this writer's header
    /// describes too (the results file of an interrupted run being continued): copies their
    /// bytes and sets the record count. Fails when `previous` has another header or fewer
    /// records.
    pub fn adopt_records(&mut self, previous: &std::path::Path, count: u64) -> Result<(), NcError> {
        let mut old = File::open(previous)?;
        let len = old.metadata()?.len();
        let mut old_header = Header::read(&mut old, len)?;
        if old_header.numrecs < count {
            return Err(NcError::Truncated(format!(
                "{} frames expected, {} found",
                count, old_header.numrecs
            )));
        }
        old_header.numrecs = 0;
        let mut own = self.header.clone();
        own.numrecs = 0;
        if old_header.encode()? != own.encode()? {
            return Err(NcError::BadHeader(
                "its variables or dimensions differ from the ones this run writes".to_string(),
            ));
        }
        old.seek(SeekFrom::Start(self.first_record))?;
        self.file.seek(SeekFrom::Start(self.first_record))?;
        let bytes = count * self.record_size;
        let copied = std::io::copy(&mut (&mut old).take(bytes), &mut self.file)?;
        if copied != bytes {
            return Err(NcError::Truncated(format!(
                "{bytes} bytes of frames expected, {copied} found"
            )));
        }
        self.header.numrecs = count;
        self.file.seek(SeekFrom::Start(4))?;
        self.file
            .write_all(&to_u32(count, "record count")?.to_be_bytes())?;
        self.file.flush()?;
        Ok(())
    }

    /// Records written so far.
    pub fn numrecs(&self) -> u64 {
        self.header.numrecs
    }

    /// Flushes everything to stable storage.
    pub fn finish(mut self) -> Result<(), NcError> {
        self.file.flush()?;
        self.file.sync_all()?;
        Ok(())
    }
}

/// Big-endian encoding helpers for the writer.
pub mod encode {
    /// `f64` values as `NC_DOUBLE`.
    pub fn doubles(values: impl IntoIterator<Item = f64>) -> Vec<u8> {
        values.into_iter().flat_map(f64::to_be_bytes).collect()
    }

    /// `i32` values as `NC_INT`.
    pub fn ints(values: impl IntoIterator<Item = i32>) -> Vec<u8> {
        values.into_iter().flat_map(i32::to_be_bytes).collect()
    }

    /// Names as a `[n][width]` char array, NUL padded (callers check the length).
    pub fn names(names: &[String], width: usize) -> Vec<u8> {
        let mut out = vec![0u8; names.len() * width];
        for (row, name) in names.iter().enumerate() {
            let bytes = name.as_bytes();
            let n = bytes.len().min(width.saturating_sub(1));
            out[row * width..row * width + n].copy_from_slice(&bytes[..n]);
        }
        out
    }
}
