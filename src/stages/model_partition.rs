//! `model.partition`: substructures of a model (docs/theory.md §9, thesis §3.3) from named element
//! sets, from property ids, or an automatic `k`-way partition (recursive coordinate bisection with
//! boundary refinement) for large models; junction DOFs and boundaries detected.

use crate::artefact::ArtefactKind;
use crate::artefact::mesh::mesh_from_artefact;
use crate::artefact::reduced::partition_to_artefact;
use crate::fe::element::MassKind;
use crate::pipeline::{
    CheckContext, ParamIssue, PortSpec, StageError, StageInputs, StageOutputs, TypedStage,
};
use crate::reduction::Partition;

/// The stage.
pub struct ModelPartition;

/// Parameters of `model.partition`: exactly one of `sets`, `by_property`, `parts`.
#[derive(Clone, Debug, Default, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// One substructure per named element set, or per list of sets (their union), e.g.
    /// `[plate_1, plate_2, bar]` or `[[beam_1, beam_3, joint_1], [beam_2]]`; every element in
    /// exactly one.
    #[serde(default)]
    pub sets: Option<Vec<SetUnion>>,
    /// One substructure per property id (`pid<N>`).
    #[serde(default)]
    pub by_property: bool,
    /// Automatic partition into this many balanced parts.
    #[serde(default)]
    pub parts: Option<usize>,
    /// Mass matrix kind the reduction will assemble (decides which DOFs hold mass).
    #[serde(default)]
    pub mass: MassKind,
}

/// One element set, or the union of several.
#[derive(Clone, Debug, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum SetUnion {
    /// One set.
    One(String),
    /// The union of these sets.
    Union(Vec<String>),
}

impl SetUnion {
    fn names(&self) -> Vec<String> {
        match self {
            SetUnion::One(s) => vec![s.clone()],
            SetUnion::Union(v) => v.clone(),
        }
    }
}

impl TypedStage for ModelPartition {
    type Params = Params;
    const KIND: &'static str = "model.partition";
    const SUMMARY: &'static str = "Substructures from element sets, property ids or an automatic k-way partition; junction DOFs";
    const IMPL_VERSION: u32 = 1;

    fn inputs() -> Vec<PortSpec> {
        vec![PortSpec::required("mesh", ArtefactKind::Mesh, "the model")]
    }

    fn outputs() -> Vec<PortSpec> {
        vec![PortSpec::required(
            "partition",
            ArtefactKind::Partition,
            "substructures, junction and internal DOFs, boundaries",
        )]
    }

    fn validate(p: &mut Params, _: &CheckContext) -> Vec<ParamIssue> {
        let given = p.sets.is_some() as usize + p.by_property as usize + p.parts.is_some() as usize;
        let mut issues = Vec::new();
        if given != 1 {
            issues.push(ParamIssue::at(
                "sets",
                "give exactly one of `sets` (element set names), `by_property: true`, or `parts` (a count)",
            ));
        }
        if p.parts == Some(0) {
            issues.push(ParamIssue::at("parts", "must be at least 1"));
        }
        if p.sets
            .as_ref()
            .is_some_and(|s| s.iter().any(|u| u.names().is_empty()))
        {
            issues.push(ParamIssue::at(
                "sets",
                "a substructure given as a list names at least one set",
            ));
        }
        if p.sets.as_ref().is_some_and(|s| s.is_empty()) {
            issues.push(ParamIssue::at("sets", "name at least one element set"));
        }
        issues
    }

    fn run(p: &Params, inputs: &StageInputs) -> Result<StageOutputs, StageError> {
        let model = mesh_from_artefact(inputs.require("mesh")?)?;
        let part = match (&p.sets, p.parts) {
            (Some(sets), _) => {
                let unions: Vec<Vec<String>> = sets.iter().map(SetUnion::names).collect();
                Partition::from_set_unions(&model, &unions, p.mass)
            }
            (_, Some(k)) => Partition::automatic(&model, k, p.mass),
            _ => Partition::from_properties(&model, p.mass),
        }
        .map_err(StageError::from_numerics(match (&p.sets, p.parts) {
            (Some(_), _) => "sets",
            (_, Some(_)) => "parts",
            _ => "",
        }))?;
        Ok(StageOutputs::from([(
            "partition".to_string(),
            partition_to_artefact(&part),
        )]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Stage, Typed};

    #[test]
    fn exactly_one_source_of_substructures() {
        let e = Typed::<ModelPartition>::new()
            .check(
                &serde_json::json!({"sets": ["a"], "parts": 3}),
                &CheckContext::default(),
            )
            .unwrap_err();
        assert!(e[0].message.contains("exactly one"), "{}", e[0].message);
        let e = Typed::<ModelPartition>::new()
            .check(&serde_json::json!({}), &CheckContext::default())
            .unwrap_err();
        assert!(e[0].message.contains("exactly one"));
    }
}
