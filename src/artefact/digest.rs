//! Canonical digests: blake3 over a format-independent encoding of an artefact, and canonical
//! JSON (sorted keys, no white space) for cache keys.

use super::{Artefact, Column};
use crate::core::hashing::StreamHasher;

/// Canonical JSON text: object keys sorted at every level, compact.
pub fn canonical_json(v: &serde_json::Value) -> String {
    let mut out = String::new();
    write_canonical(v, &mut out);
    out
}

fn write_canonical(v: &serde_json::Value, out: &mut String) {
    match v {
        serde_json::Value::Object(map) => {
            let mut keys: Vec<&String> = map.keys().collect();
            keys.sort();
            out.push('{');
            for (i, k) in keys.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                out.push_str(&serde_json::Value::String((*k).clone()).to_string());
                out.push(':');
                write_canonical(&map[*k], out);
            }
            out.push('}');
        }
        serde_json::Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write_canonical(item, out);
            }
            out.push(']');
        }
        other => out.push_str(&other.to_string()),
    }
}

/// blake3 of `bytes`, hex.
pub fn hash_bytes(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

/// blake3 of a file's bytes, hex, read in 1 MiB pieces (memory does not grow with the file);
/// equal to [`hash_bytes`] of the whole file.
pub fn hash_file(path: &std::path::Path) -> std::io::Result<String> {
    use std::io::Read;
    let mut file = std::fs::File::open(path)?;
    let mut hasher = blake3::Hasher::new();
    let mut buffer = vec![0u8; 1 << 20];
    loop {
        match file.read(&mut buffer) {
            Ok(0) => break,
            Ok(n) => {
                hasher.update(&buffer[..n]);
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(hasher.finalize().to_hex().to_string())
}

/// The content digest of an artefact: kind, schema version, canonical metadata, every table's
/// columns (name, type, values as little-endian bytes) and every blob, in sorted order.
pub fn artefact_digest(a: &Artefact) -> String {
    let mut h = StreamHasher::new();
    h.field(b"femu-artefact-v1");
    h.field(a.kind.name().as_bytes());
    h.field(&a.kind.schema_version().to_le_bytes());
    h.field(canonical_json(&serde_json::Value::Object(a.meta.clone())).as_bytes());
    for (name, (table, _)) in &a.tables {
        h.field(name.as_bytes());
        for (cname, col) in &table.columns {
            h.field(cname.as_bytes());
            h.field(col.type_name().as_bytes());
            h.bytes(&(col.len() as u64).to_le_bytes());
            match col {
                // -0.0 and 0.0 hash alike; every NaN hashes alike. A column without -0.0 and
                // other NaNs (nearly every one) is its own canonical bytes.
                Column::F64(v) => {
                    use rayon::prelude::*;
                    let canonical = |x: f64| {
                        if x == 0.0 {
                            0u64
                        } else if x.is_nan() {
                            f64::NAN.to_bits()
                        } else {
                            x.to_bits()
                        }
                    };
                    if v.par_iter().all(|&x| canonical(x) == x.to_bits()) {
                        h.le_values(v, f64::to_le_bytes);
                    } else {
                        h.values(v, |x| canonical(x).to_le_bytes());
                    }
                }
                Column::I64(v) => h.le_values(v, i64::to_le_bytes),
                Column::I32(v) => h.le_values(v, i32::to_le_bytes),
                Column::Str(v) => h.fields(v),
            }
        }
    }
    for (name, bytes) in &a.blobs {
        h.field(name.as_bytes());
        h.field(bytes);
    }
    h.finish().to_hex().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artefact::{ArtefactKind, Storage, Table};

    #[test]
    fn canonical_json_sorts_keys() {
        let v: serde_json::Value =
            serde_json::from_str(r#"{"b":1,"a":{"d":[1,2],"c":null}}"#).unwrap();
        assert_eq!(canonical_json(&v), r#"{"a":{"c":null,"d":[1,2]},"b":1}"#);
    }

    #[test]
    fn buffering_does_not_change_the_digest() {
        // Columns larger than the buffer, strings and a blob, against the stream hashed at once.
        let x: Vec<f64> = (0..300_000).map(|i| (i as f64).sin()).collect();
        let n: Vec<i64> = (0..200_000).map(|i| i * 7 - 3).collect();
        let i: Vec<i32> = (0..150_000).map(|i| i * 5 - 7).collect();
        // Values that are not their own canonical bytes: -0.0 and a NaN of another payload.
        let mut z = x.clone();
        (z[7], z[200_000]) = (-0.0, f64::from_bits(f64::NAN.to_bits() | 1));
        // More labels than one batch of the parallel encoding, of every length from 0 to 12.
        let labels: Vec<String> = (0..300_000).map(|k| "ab".repeat(k % 7)).collect();
        let table = Table::new()
            .with("x", Column::F64(x.clone()))
            .with("n", Column::I64(n.clone()))
            .with("i", Column::I32(i.clone()))
            .with("z", Column::F64(z.clone()))
            .with("s", Column::Str(labels.clone()));
        let mut a = Artefact::new(ArtefactKind::Frf).with_table("t", table, Storage::Parquet);
        a.blobs.insert("b".into(), vec![7u8; 3 << 20]);
        let mut stream = Vec::new();
        let field = |s: &mut Vec<u8>, b: &[u8]| {
            s.extend_from_slice(&(b.len() as u64).to_le_bytes());
            s.extend_from_slice(b);
        };
        field(&mut stream, b"femu-artefact-v1");
        field(&mut stream, a.kind.name().as_bytes());
        field(&mut stream, &a.kind.schema_version().to_le_bytes());
        field(&mut stream, b"{}");
        field(&mut stream, b"t");
        // Columns in the table's own order: x, n, i, z, s.
        let floats = |stream: &mut Vec<u8>, name: &[u8], x: &[f64]| {
            field(stream, name);
            field(stream, b"float64");
            stream.extend_from_slice(&(x.len() as u64).to_le_bytes());
            x.iter().for_each(|v| {
                let bits = match *v {
                    0.0 => 0u64,
                    v if v.is_nan() => f64::NAN.to_bits(),
                    v => v.to_bits(),
                };
                stream.extend_from_slice(&bits.to_le_bytes())
            });
        };
        floats(&mut stream, b"x", &x);
        field(&mut stream, b"n");
        field(&mut stream, b"int64");
        stream.extend_from_slice(&(n.len() as u64).to_le_bytes());
        n.iter()
            .for_each(|v| stream.extend_from_slice(&v.to_le_bytes()));
        field(&mut stream, b"i");
        field(&mut stream, b"int32");
        stream.extend_from_slice(&(i.len() as u64).to_le_bytes());
        i.iter()
            .for_each(|v| stream.extend_from_slice(&v.to_le_bytes()));
        floats(&mut stream, b"z", &z);
        field(&mut stream, b"s");
        field(&mut stream, b"string");
        stream.extend_from_slice(&(labels.len() as u64).to_le_bytes());
        labels.iter().for_each(|l| field(&mut stream, l.as_bytes()));
        field(&mut stream, b"b");
        field(&mut stream, &vec![7u8; 3 << 20]);
        assert_eq!(a.digest(), hash_bytes(&stream));
        let path = std::env::temp_dir().join(format!("femu-hash-file-{}", std::process::id()));
        std::fs::write(&path, &stream).unwrap();
        let (file, bytes) = (hash_file(&path).unwrap(), hash_bytes(&stream));
        std::fs::remove_file(&path).unwrap();
        assert_eq!(
            file, bytes,
            "a file hashed in pieces equals its bytes hashed at once"
        );
    }

    #[test]
    fn digest_sees_every_value() {
        let t = |x: f64| Table::new().with("v", Column::F64(vec![1.0, x]));
        let a = Artefact::new(ArtefactKind::Frf).with_table("t", t(2.0), Storage::Parquet);
        let b = Artefact::new(ArtefactKind::Frf).with_table("t", t(2.0 + 1e-15), Storage::Parquet);
        let c = Artefact::new(ArtefactKind::Frf).with_table("t", t(2.0), Storage::Ipc);
        assert_ne!(a.digest(), b.digest());
        assert_eq!(a.digest(), c.digest(), "storage choice is not content");
    }
}
