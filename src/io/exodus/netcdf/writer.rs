//! Writing a netCDF-3 file that is complete after every record.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};

use super::{pad4, to_u32, Header, NcError, Variable};

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
