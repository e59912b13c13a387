//! Canonical digests: blake3 over a format-independent encoding of an artefact, and canonical
//! JSON (sorted keys, no white space) for cache keys.

use super::{Artefact, Column};

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

/// The content digest of an artefact: kind, schema version, canonical metadata, every table's
/// columns (name, type, values as little-endian bytes) and every blob, in sorted order.
pub fn artefact_digest(a: &Artefact) -> String {
    let mut h = blake3::Hasher::new();
    let field = |h: &mut blake3::Hasher, bytes: &[u8]| {
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    field(&mut h, b"femu-artefact-v1");
    field(&mut h, a.kind.name().as_bytes());
    field(&mut h, &a.kind.schema_version().to_le_bytes());
    field(
        &mut h,
        canonical_json(&serde_json::Value::Object(a.meta.clone())).as_bytes(),
    );
    for (name, (table, _)) in &a.tables {
        field(&mut h, name.as_bytes());
        for (cname, col) in &table.columns {
            field(&mut h, cname.as_bytes());
            field(&mut h, col.type_name().as_bytes());
            h.update(&(col.len() as u64).to_le_bytes());
            match col {
                Column::F64(v) => {
                    for x in v {
                        // -0.0 and 0.0 hash alike; every NaN hashes alike.
                        let bits = if *x == 0.0 {
                            0u64
                        } else if x.is_nan() {
                            f64::NAN.to_bits()
                        } else {
                            x.to_bits()
                        };
                        h.update(&bits.to_le_bytes());
                    }
                }
                Column::I64(v) => {
                    for x in v {
                        h.update(&x.to_le_bytes());
                    }
                }
                Column::Str(v) => {
                    for s in v {
                        field(&mut h, s.as_bytes());
                    }
                }
            }
        }
    }
    for (name, bytes) in &a.blobs {
        field(&mut h, name.as_bytes());
        field(&mut h, bytes);
    }
    h.finalize().to_hex().to_string()
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
    fn digest_sees_every_value() {
        let t = |x: f64| Table::new().with("v", Column::F64(vec![1.0, x]));
        let a = Artefact::new(ArtefactKind::Frf).with_table("t", t(2.0), Storage::Parquet);
        let b = Artefact::new(ArtefactKind::Frf).with_table("t", t(2.0 + 1e-15), Storage::Parquet);
        let c = Artefact::new(ArtefactKind::Frf).with_table("t", t(2.0), Storage::Ipc);
        assert_ne!(a.digest(), b.digest());
        assert_eq!(a.digest(), c.digest(), "storage choice is not content");
    }
}
