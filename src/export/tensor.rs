//! The `tensor_file` container of the RGL material database (Dupuy & Jakob 2018), as the
//! reference loaders read it (rgl-epfl/brdf-loader, Mitsuba 3's `TensorFile`, pbrt-v4's
//! `Tensor`):
//!
//! - 12 bytes `"tensor_file\0"`, then the version as two bytes (major 1, minor 0), then the
//!   field count as a little-endian u32;
//! - per field: name length (u16) and name (UTF-8), dimension count (u16), dtype (u8),
//!   offset of the data from the start of the file (u64), then one u64 per dimension;
//! - the data of each field, little-endian and C-ordered (last dimension contiguous), at its
//!   offset. Offsets here are aligned to 8 bytes, as the database's own writer does.

use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use std::io::Write;
use std::path::Path;

const MAGIC: &[u8; 12] = b"tensor_file\0";
const VERSION: [u8; 2] = [1, 0];
const ALIGN: u64 = 8;

/// The element types a tensor file can hold (the loaders' numbering).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum DType {
    UInt8 = 1,
    Int8 = 2,
    UInt16 = 3,
    Int16 = 4,
    UInt32 = 5,
    Int32 = 6,
    UInt64 = 7,
    Int64 = 8,
    Float16 = 9,
    Float32 = 10,
    Float64 = 11,
}

impl DType {
    fn from_code(code: u8) -> Option<Self> {
        use DType::*;
        Some(match code {
            1 => UInt8,
            2 => Int8,
            3 => UInt16,
            4 => Int16,
            5 => UInt32,
            6 => Int32,
            7 => UInt64,
            8 => Int64,
            9 => Float16,
            10 => Float32,
            11 => Float64,
            _ => return None,
        })
    }

    /// Bytes per element.
    pub fn size(self) -> usize {
        use DType::*;
        match self {
            UInt8 | Int8 => 1,
            UInt16 | Int16 | Float16 => 2,
            UInt32 | Int32 | Float32 => 4,
            UInt64 | Int64 | Float64 => 8,
        }
    }
}

/// One named array of a tensor file.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    pub name: String,
    pub dtype: DType,
    pub shape: Vec<u64>,
    /// Little-endian element bytes, C order.
    pub data: Vec<u8>,
}

impl Field {
    /// A float32 array of `shape`; `values` must hold their product.
    pub fn f32(name: &str, shape: &[usize], values: &[f32]) -> Self {
        assert_eq!(
            shape.iter().product::<usize>(),
            values.len(),
            "field {name}: shape and data disagree"
        );
        Self {
            name: name.into(),
            dtype: DType::Float32,
            shape: shape.iter().map(|&s| s as u64).collect(),
            data: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        }
    }

    /// A one-dimensional byte array (how the format stores text and flags).
    pub fn bytes(name: &str, bytes: &[u8]) -> Self {
        Self {
            name: name.into(),
            dtype: DType::UInt8,
            shape: vec![bytes.len() as u64],
            data: bytes.to_vec(),
        }
    }

    /// Elements in the array.
    pub fn len(&self) -> usize {
        self.shape.iter().product::<u64>() as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The values of a float32 field.
    pub fn as_f32(&self) -> Option<Vec<f32>> {
        (self.dtype == DType::Float32).then(|| {
            self.data
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
                .collect()
        })
    }
}

/// A whole tensor file: its fields in file order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TensorFile {
    pub fields: Vec<Field>,
}

impl TensorFile {
    /// The field called `name`.
    pub fn field(&self, name: &str) -> Option<&Field> {
        self.fields.iter().find(|f| f.name == name)
    }

    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        // Header size first: every offset depends on it.
        let mut header_len = (MAGIC.len() + VERSION.len() + 4) as u64;
        for f in &self.fields {
            header_len += 2 + f.name.len() as u64 + 2 + 1 + 8 + 8 * f.shape.len() as u64;
        }
        let mut offsets = Vec::with_capacity(self.fields.len());
        let mut end = header_len;
        for f in &self.fields {
            let start = end.div_ceil(ALIGN) * ALIGN;
            offsets.push(start);
            end = start + f.data.len() as u64;
        }
        let mut out = Vec::with_capacity(end as usize);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION);
        out.extend_from_slice(&(self.fields.len() as u32).to_le_bytes());
        for (f, &offset) in self.fields.iter().zip(&offsets) {
            out.extend_from_slice(&(f.name.len() as u16).to_le_bytes());
            out.extend_from_slice(f.name.as_bytes());
            out.extend_from_slice(&(f.shape.len() as u16).to_le_bytes());
            out.push(f.dtype as u8);
            out.extend_from_slice(&offset.to_le_bytes());
            for &s in &f.shape {
                out.extend_from_slice(&s.to_le_bytes());
            }
        }
        debug_assert_eq!(out.len() as u64, header_len);
        for (f, &offset) in self.fields.iter().zip(&offsets) {
            out.resize(offset as usize, 0);
            out.extend_from_slice(&f.data);
        }
        out
    }

    /// Writes the file atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = self.to_bytes();
        write_atomically(path, |w| w.write_all(&bytes))
    }

    /// Reads a tensor file; every field's data must lie inside the file.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Self::parse(&bytes).map_err(|problem| Error::invalid(path, problem))
    }

    /// Parses a tensor file's bytes; the error says what is wrong, without the path.
    pub fn parse(bytes: &[u8]) -> std::result::Result<Self, String> {
        let mut cursor = Cursor { bytes, at: 0 };
        if cursor.take(12)? != MAGIC {
            return Err("not a tensor file (the header is not \"tensor_file\")".into());
        }
        let version = cursor.take(2)?;
        if version != VERSION {
            return Err(format!(
                "tensor file version {}.{} is not 1.0",
                version[0], version[1]
            ));
        }
        let count = cursor.u32()?;
        let mut fields = Vec::new();
        for i in 0..count {
            let name_len = cursor.u16()? as usize;
            let name = String::from_utf8(cursor.take(name_len)?.to_vec())
                .map_err(|_| format!("field {i}: the name is not UTF-8"))?;
            let ndim = cursor.u16()? as usize;
            let code = cursor.take(1)?[0];
            let dtype = DType::from_code(code)
                .ok_or_else(|| format!("field {name}: unknown element type {code}"))?;
            let offset = cursor.u64()?;
            let mut shape = Vec::with_capacity(ndim);
            for _ in 0..ndim {
                shape.push(cursor.u64()?);
            }
            let len = shape
                .iter()
                .try_fold(dtype.size() as u64, |acc, &s| acc.checked_mul(s))
                .ok_or_else(|| format!("field {name}: shape {shape:?} overflows"))?;
            let end = offset
                .checked_add(len)
                .filter(|&e| e <= bytes.len() as u64)
                .ok_or_else(|| {
                    format!(
                        "field {name}: {len} bytes at offset {offset} run past the end of the \
                         {}-byte file (truncated?)",
                        bytes.len()
                    )
                })?;
            fields.push(Field {
                name,
                dtype,
                shape,
                data: bytes[offset as usize..end as usize].to_vec(),
            });
        }
        Ok(Self { fields })
    }
}

struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> std::result::Result<&'a [u8], String> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| "the header is cut short (truncated file?)".to_string())?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }
    fn u16(&mut self) -> std::result::Result<u16, String> {
        Ok(u16::from_le_bytes(self.take(2)?.try_into().expect("2")))
    }
    fn u32(&mut self) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4")))
    }
    fn u64(&mut self) -> std::result::Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_matches_the_reference_loader() {
        let file = TensorFile {
            fields: vec![
                Field::bytes("description", b"hi"),
                Field::f32("theta_i", &[2], &[0.5, 1.5]),
            ],
        };
        let bytes = file.to_bytes();
        assert_eq!(&bytes[..12], b"tensor_file\0");
        assert_eq!(&bytes[12..14], &[1, 0]);
        assert_eq!(u32::from_le_bytes(bytes[14..18].try_into().unwrap()), 2);
        // Field 0: name length 11, "description", ndim 1, dtype UInt8, offset, shape [2].
        assert_eq!(u16::from_le_bytes(bytes[18..20].try_into().unwrap()), 11);
        assert_eq!(&bytes[20..31], b"description");
        assert_eq!(u16::from_le_bytes(bytes[31..33].try_into().unwrap()), 1);
        assert_eq!(bytes[33], 1);
        let offset = u64::from_le_bytes(bytes[34..42].try_into().unwrap()) as usize;
        assert_eq!(offset % 8, 0);
        assert_eq!(&bytes[offset..offset + 2], b"hi");
        let parsed = TensorFile::parse(&bytes).unwrap();
        assert_eq!(parsed, file);
        assert_eq!(
            parsed.field("theta_i").unwrap().as_f32().unwrap(),
            vec![0.5, 1.5]
        );
    }

    #[test]
    fn damage_is_reported() {
        let file = TensorFile {
            fields: vec![Field::f32("ndf", &[2, 2], &[1.0; 4])],
        };
        let bytes = file.to_bytes();
        let truncated = &bytes[..bytes.len() - 3];
        assert!(
            TensorFile::parse(truncated)
                .unwrap_err()
                .contains("truncated")
        );
        let mut wrong = bytes.clone();
        wrong[0] = b'x';
        assert!(
            TensorFile::parse(&wrong)
                .unwrap_err()
                .contains("not a tensor file")
        );
        let mut version = bytes.clone();
        version[12] = 2;
        assert!(
            TensorFile::parse(&version)
                .unwrap_err()
                .contains("version 2.0")
        );
        assert!(TensorFile::parse(&bytes[..20]).is_err());
    }
}
