//! Reading variables of a netCDF-3 file, whole or one record at a time.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};

use super::{decode_f64, text_from_bytes, Header, NcError, NcType, Variable};

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
