//! Degree-of-freedom identifiers, `node:comp`.
//!
//! A DOF is a node id and one of six components, or the single DOF of a scalar point (Nastran
//! SPOINT/EPOINT: one DOF without position, component [`Component::Scalar`]). The text form is
//! `12:ux` (components `ux uy uz rx ry rz`, `s` for a scalar point); the Nastran form `12:3`
//! (components 1–6, 0 for a scalar point) is accepted on input.
//! Everything downstream matches DOFs by [`DofId`], never by row number.

use std::fmt;
use std::str::FromStr;

/// One of the six nodal components, or the one DOF of a scalar point.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Component {
    /// Translation along x.
    Ux,
    /// Translation along y.
    Uy,
    /// Translation along z.
    Uz,
    /// Rotation about x.
    Rx,
    /// Rotation about y.
    Ry,
    /// Rotation about z.
    Rz,
    /// The single DOF of a scalar point (Nastran component 0); never a grid's component.
    Scalar,
}

impl Component {
    /// All six components in Nastran order.
    pub const ALL: [Component; 6] = [
        Component::Ux,
        Component::Uy,
        Component::Uz,
        Component::Rx,
        Component::Ry,
        Component::Rz,
    ];

    /// Text name (`ux` … `rz`).
    pub fn name(self) -> &'static str {
        match self {
            Component::Ux => "ux",
            Component::Uy => "uy",
            Component::Uz => "uz",
            Component::Rx => "rx",
            Component::Ry => "ry",
            Component::Rz => "rz",
            Component::Scalar => "s",
        }
    }

    /// Nastran component number 1–6 (0 for a scalar point).
    pub fn nastran(self) -> u8 {
        match self {
            Component::Scalar => 0,
            c => c as u8 + 1,
        }
    }

    /// Position in a node's 6-DOF block (a scalar point's DOF is slot 0 of its block).
    pub fn slot(self) -> usize {
        match self {
            Component::Scalar => 0,
            c => c as usize,
        }
    }

    /// True for the scalar point's component.
    pub fn is_scalar(self) -> bool {
        self == Component::Scalar
    }

    /// Component from its Nastran number 1–6.
    pub fn from_nastran(c: u8) -> Option<Self> {
        Component::ALL.get((c as usize).wrapping_sub(1)).copied()
    }

    /// True for the three rotations.
    pub fn is_rotation(self) -> bool {
        matches!(self, Component::Rx | Component::Ry | Component::Rz)
    }
}

/// A degree of freedom: node id and component.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct DofId {
    /// Node (grid point) id.
    pub node: u64,
    /// Component at that node.
    pub comp: Component,
}

impl DofId {
    /// A DOF from node and component.
    pub fn new(node: u64, comp: Component) -> Self {
        DofId { node, comp }
    }
}

impl fmt::Display for DofId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.node, self.comp.name())
    }
}

/// Why a DOF label could not be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "`{label}` is not a DOF label: {reason}; write `node:comp` with comp one of ux uy uz rx ry rz (or 1-6), or s (or 0) for a scalar point, e.g. `12:uz`"
)]
pub struct DofParseError {
    /// The text that failed.
    pub label: String,
    /// What is wrong with it.
    pub reason: &'static str,
}

impl FromStr for DofId {
    type Err = DofParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = |reason| DofParseError {
            label: s.to_string(),
            reason,
        };
        let (node, comp) = s.trim().split_once(':').ok_or_else(|| err("no `:`"))?;
        let node: u64 = node
            .trim()
            .parse()
            .map_err(|_| err("the node id is not a non-negative integer"))?;
        let comp = comp.trim();
        let comp = match comp.to_ascii_lowercase().as_str() {
            "ux" | "x" | "tx" => Component::Ux,
            "uy" | "y" | "ty" => Component::Uy,
            "uz" | "z" | "tz" => Component::Uz,
            "rx" => Component::Rx,
            "ry" => Component::Ry,
            "rz" => Component::Rz,
            "s" | "0" => Component::Scalar,
            other => other
                .parse::<u8>()
                .ok()
                .and_then(Component::from_nastran)
                .ok_or_else(|| err("unknown component"))?,
        };
        Ok(DofId { node, comp })
    }
}

impl serde::Serialize for DofId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> serde::Deserialize<'de> for DofId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

impl schemars::JsonSchema for DofId {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "DofId".into()
    }

    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "type": "string",
            "pattern": "^[0-9]+:(ux|uy|uz|rx|ry|rz|[1-6]|s|0)$",
            "description": "A degree of freedom `node:comp`, e.g. `12:uz` (`1001:s` for a scalar point)"
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_and_nastran_forms_round_trip() {
        let d: DofId = "12:uz".parse().unwrap();
        assert_eq!(d, DofId::new(12, Component::Uz));
        assert_eq!(d.to_string(), "12:uz");
        assert_eq!("12:3".parse::<DofId>().unwrap(), d);
        assert_eq!("7:6".parse::<DofId>().unwrap().comp, Component::Rz);
        let s: DofId = "1001:s".parse().unwrap();
        assert_eq!(s, DofId::new(1001, Component::Scalar));
        assert_eq!(s.to_string(), "1001:s");
        assert_eq!("1001:0".parse::<DofId>().unwrap(), s);
        assert_eq!(Component::Scalar.nastran(), 0);
        assert_eq!(Component::Scalar.slot(), 0);
        assert_eq!(Component::from_nastran(0), None);
    }

    #[test]
    fn bad_labels_say_what_is_valid() {
        for bad in ["12", "a:ux", "3:uq", "3:7", "3:-1", "-1:ux"] {
            let e = bad.parse::<DofId>().unwrap_err();
            assert!(e.to_string().contains("node:comp"), "{e}");
        }
    }
}
