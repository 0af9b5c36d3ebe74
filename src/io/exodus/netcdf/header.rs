//! The header's bytes: [`Header::read`] parses it, [`Header::layout`] assigns the variables'
//! offsets and encodes it (big-endian, every item padded to 4 bytes).

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};

use super::{
    pad4, to_u32, AttrValue, Attribute, Dimension, Header, NcError, NcFormat, NcType, Variable,
    NC_ATTRIBUTE, NC_DIMENSION, NC_VARIABLE, STREAMING,
};

impl Header {
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

    /// The header's bytes, with the variables' offsets as they are.
    pub(super) fn encode(&self) -> Result<Vec<u8>, NcError> {
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
