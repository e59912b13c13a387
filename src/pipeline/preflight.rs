//! Checks before anything runs that need what upstream stages give (`femu validate`).
//!
//! Planning checks each stage's parameters alone. Some mistakes show only against an input: a
//! parameter on a set the model does not have, a thickness on a beam property, a measured DOF
//! at a node the model lacks. Here the stages that only read files or build a small model
//! ([`TypedStage::PREFLIGHT`](super::TypedStage::PREFLIGHT): imports, generated meshes,
//! parameter declarations, pairing) are run in memory, nothing cached, and every stage whose
//! inputs are then all known gets its [`Stage::preflight`](super::Stage::preflight) check.
//! Each finding is reported at its stage and field, with the line of the pipeline file. A
//! stage that fails here is reported the same way, and nothing downstream of it is checked.

use super::plan::Plan;
use super::spec::SourcedSpec;
use super::stage::{StageInputs, StageOutputs};
use super::{Diagnostic, Diagnostics};
use std::collections::BTreeMap;
use std::sync::Arc;

/// The findings of the checks against upstream outputs; empty when there are none.
pub fn preflight(src: &SourcedSpec, plan: &Plan) -> Diagnostics {
    let mut outputs: BTreeMap<usize, StageOutputs> = BTreeMap::new();
    let mut diags = Vec::new();
    for (i, node) in plan.nodes.iter().enumerate() {
        let mut inputs = StageInputs {
            base_dir: plan.base_dir.clone(),
            ..Default::default()
        };
        let known = node.inputs.iter().all(|(port, r)| {
            match outputs.get(&r.node).and_then(|o| o.get(&r.port)) {
                Some(a) => {
                    inputs.artefacts.insert(port.clone(), Arc::new(a.clone()));
                    true
                }
                None => false,
            }
        });
        if !known {
            continue;
        }
        let issues = node.stage.preflight(&node.params, &inputs);
        let failed = !issues.is_empty();
        for issue in issues {
            let mut path = vec!["stages", node.name.as_str(), "with"];
            path.extend(issue.path.iter().map(String::as_str));
            let field = std::iter::once("with")
                .chain(issue.path.iter().map(String::as_str))
                .collect::<Vec<_>>()
                .join(".");
            let pos = src
                .locator
                .value(&path)
                .or_else(|| src.locator.key(&["stages", node.name.as_str()]));
            diags.push(
                Diagnostic::new(&src.file, issue.message)
                    .at(pos)
                    .stage(&node.name)
                    .field(field),
            );
        }
        if failed || !node.stage.runs_in_preflight() {
            continue;
        }
        match node.stage.run(&node.params, &inputs) {
            Ok(out) => {
                outputs.insert(i, out);
            }
            Err(e) => diags.push(
                Diagnostic::new(&src.file, e.to_string())
                    .at(src.locator.key(&["stages", node.name.as_str()]))
                    .stage(&node.name)
                    .help("found by running the stage while checking; fix it before running the pipeline"),
            ),
        }
    }
    Diagnostics(diags)
}
