//! Putting the model together: grids placed, elements built, constraints and sets resolved,
//! the model validated and every element checked as the assembly will build it.

use super::*;

/// Where the cards behind the model's entities are, for messages after the model is built.
#[derive(Default)]
struct Origins {
    elements: BTreeMap<u64, Loc>,
    constraints: BTreeMap<u64, Loc>,
    sets: BTreeMap<String, Loc>,
    parameters: Vec<(String, Loc)>,
}

impl Builder {
    pub(super) fn finish(
        mut self,
        set_names: Vec<(Loc, u64, String)>,
        parameters: Vec<(Loc, Parameter)>,
    ) -> Result<BulkImport, NastranError> {
        let mut model = Model::default();
        let mut origins = Origins::default();
        self.place_grids(&mut model)?;
        for (id, m) in &self.materials {
            model.materials.insert(*id, m.1.clone());
        }
        model.shell_properties = std::mem::take(&mut self.shells);
        model.beam_properties = std::mem::take(&mut self.beams);
        for (id, (loc, e)) in std::mem::take(&mut self.elements) {
            let element = self.resolve_element(&model, &loc, e)?;
            model.elements.insert(id, element);
            origins.elements.insert(id, loc);
        }
        self.resolve_constraints(&mut model, &mut origins);
        self.resolve_sets(&mut model, &mut origins, set_names)?;
        for (loc, p) in parameters {
            origins.parameters.push((p.name.clone(), loc));
            model.parameters.push(p);
        }
        model.add_property_sets();
        if let Err(e) = model.validate() {
            return Err(self.locate_model_error(e, &origins));
        }
        if model.elements.is_empty() {
            return Err(NastranError::Empty {
                file: self.top_file.to_string().into(),
                problem: format!(
                    "no element was read ({} GRID card(s)), so there is no stiffness or mass to assemble",
                    model.nodes.len()
                )
                .into(),
                valid: format!(
                    "a bulk data deck with elements femu reads (femu reads {})",
                    READ_CARDS.join(", ")
                )
                .into(),
            });
        }
        self.check_elements(&model, &origins)?;
        let mut unknown = self.skipped.clone();
        for (k, n) in &self.ignored {
            *unknown.entry(k.clone()).or_insert(0) += n;
        }
        Ok(BulkImport {
            model,
            unknown,
            skipped: self.skipped,
            ignored: self.ignored,
            warnings: self.warnings,
        })
    }

    /// Grid points in the basic system; PS components become constraints.
    fn place_grids(&mut self, model: &mut Model) -> Result<(), NastranError> {
        let frames = self.frames()?;
        let mut cd_grids: Vec<(u64, i64, Loc)> = Vec::new();
        for (&id, g) in &self.grids {
            let x = if g.cp == 0 {
                g.x
            } else if let Some(f) = frames.get(&g.cp) {
                f.to_basic(g.x)
            } else {
                return Err(g.loc.field_err(
                    2,
                    "CP",
                    format!("coordinate system {} is not a CORD2R of the deck", g.cp),
                    "0 (basic) or the id of a CORD2R card (other coordinate system cards are not supported)",
                ));
            };
            model.nodes.insert(id, x);
            if g.cd != 0 {
                cd_grids.push((id, g.cd, g.loc.clone()));
            }
            for &comp in &g.ps {
                self.spcs.push((g.loc.clone(), DofId::new(id, comp)));
            }
        }
        if let Some((id, cd, loc)) = cd_grids.first() {
            self.warnings.push(format!(
                "{} line {}: GRID {id} has CD {cd} ({} grid(s) with CD != 0 in all); CD is ignored: displacements, PS/SPC components and spring directions are taken in the basic system",
                loc.file,
                loc.line,
                cd_grids.len()
            ));
        }
        Ok(())
    }

    /// An element as the model holds it, its references to other cards resolved.
    fn resolve_element(
        &self,
        model: &Model,
        loc: &Loc,
        e: ElemIn,
    ) -> Result<Element, NastranError> {
        Ok(match e {
            ElemIn::Done(e) => e,
            ElemIn::Beam {
                nodes,
                property,
                orient,
            } => Element::Beam {
                nodes,
                property,
                orientation: beam_orientation(model, loc, nodes, orient)?,
            },
            ElemIn::Celas1 { pid, dof, other } => {
                let Some(&k) = self.pelas.get(&pid) else {
                    return Err(loc.field_err(
                        2,
                        "PID",
                        format!("property {pid} is not a PELAS"),
                        "the id of a PELAS card",
                    ));
                };
                Element::ScalarSpring { dof, other, k }
            }
            ElemIn::Bush { pid, node, other } => {
                let Some(&k) = self.pbush.get(&pid) else {
                    return Err(loc.field_err(
                        2,
                        "PID",
                        format!("property {pid} is not a PBUSH"),
                        "the id of a PBUSH card",
                    ));
                };
                Element::Bush { node, other, k }
            }
            ElemIn::MassAbsolute {
                node,
                mass,
                inertia,
                cg,
            } => {
                let at = model.nodes.get(&node).copied().unwrap_or([0.0; 3]);
                Element::Mass {
                    node,
                    mass,
                    inertia,
                    offset: sub(cg, at),
                }
            }
        })
    }

    /// SPC1 THRU ranges over the grids that exist, merged with SPC and PS into one sorted list.
    fn resolve_constraints(&mut self, model: &mut Model, origins: &mut Origins) {
        for (loc, comps, lo, hi) in &self.spc_ranges {
            for &g in model.nodes.range(lo..=hi).map(|(g, _)| g) {
                for &comp in comps {
                    self.spcs.push((loc.clone(), DofId::new(g, comp)));
                }
            }
        }
        if self.spc_sids.len() > 1 {
            let sids: Vec<String> = self.spc_sids.iter().map(u64::to_string).collect();
            self.warnings.push(format!(
                "{}: SPC/SPC1 sets {} are merged into one constraint list (there is no case control to choose one)",
                self.top_file,
                sids.join(", ")
            ));
        }
        for (loc, d) in &self.spcs {
            origins
                .constraints
                .entry(d.node)
                .or_insert_with(|| loc.clone());
        }
        let mut constraints: Vec<DofId> = self.spcs.iter().map(|(_, d)| *d).collect();
        constraints.sort();
        constraints.dedup();
        model.constraints = constraints;
    }

    /// SET1 cards (THRU over existing elements) and `$femu-set` names become named sets.
    fn resolve_sets(
        &mut self,
        model: &mut Model,
        origins: &mut Origins,
        set_names: Vec<(Loc, u64, String)>,
    ) -> Result<(), NastranError> {
        let mut names: BTreeMap<u64, (Loc, String)> = BTreeMap::new();
        for (loc, sid, name) in set_names {
            if let Some((first, _)) = names.get(&sid) {
                return Err(NastranError::Syntax {
                    file: loc.file.to_string().into(),
                    line: loc.line,
                    problem: format!("set {sid} is named twice (first at {})", first.place())
                        .into(),
                    valid: "one `$femu-set` comment per set id".into(),
                });
            }
            names.insert(sid, (loc, name));
        }
        let sets = std::mem::take(&mut self.sets);
        let mut all_sids: BTreeSet<u64> = sets.keys().copied().collect();
        all_sids.extend(names.keys().copied());
        for sid in all_sids {
            let (loc, mut ids) = match sets.get(&sid) {
                Some(s) => {
                    let mut ids = s.ids.clone();
                    for (lo, hi) in &s.ranges {
                        ids.extend(model.elements.range(lo..=hi).map(|(e, _)| *e));
                    }
                    (s.loc.clone(), ids)
                }
                None => (names[&sid].0.clone(), Vec::new()),
            };
            ids.sort_unstable();
            ids.dedup();
            let name = names
                .get(&sid)
                .map_or_else(|| format!("set{sid}"), |(_, n)| n.clone());
            if let Some(first) = origins.sets.get(&name) {
                return Err(NastranError::Syntax {
                    file: loc.file.to_string().into(),
                    line: loc.line,
                    problem: format!("set `{name}` is defined twice (first at {})", first.place())
                        .into(),
                    valid: "set names must be unique".into(),
                });
            }
            origins.sets.insert(name.clone(), loc);
            model.sets.insert(name, ids);
        }
        Ok(())
    }

    /// A failed model check, placed at the card that holds the dangling reference.
    fn locate_model_error(&self, e: ModelError, origins: &Origins) -> NastranError {
        let pid_loc = |p: &u64| self.pids.get(p).cloned();
        let (loc, valid) = match &e {
            ModelError::MissingNode { element, node, .. } => (
                origins.elements.get(element).cloned(),
                format!("add GRID {node} or correct the element's grid ids"),
            ),
            ModelError::MissingProperty { element, .. } => (
                origins.elements.get(element).cloned(),
                "CQUAD4/CTRIA3 need a PSHELL; CBAR/CBEAM need a PBAR, PBARL or PBEAM".to_string(),
            ),
            ModelError::MissingMaterial { property, material } => {
                (pid_loc(property), format!("add MAT1 {material}"))
            }
            ModelError::MissingSetElement { set, element } => (
                origins.sets.get(set).cloned(),
                format!(
                    "SET1 lists element ids: define element {element} or remove it from the set"
                ),
            ),
            ModelError::MissingSet { parameter, .. } => (
                origins
                    .parameters
                    .iter()
                    .find(|(n, _)| n == parameter)
                    .map(|(_, l)| l.clone()),
                "name a set defined by SET1 or a `pid<N>` property set".to_string(),
            ),
            ModelError::ConstraintNode(node) => (
                origins.constraints.get(node).cloned(),
                format!("add GRID {node} or remove it from the SPC/SPC1"),
            ),
        };
        let (file, line) = loc.map_or((self.top_file.to_string(), 0), |l| {
            (l.file.to_string(), l.line)
        });
        NastranError::Model {
            file: file.into(),
            line,
            source: e,
            valid: valid.into(),
        }
    }

    /// Every element as the assembly will build it, so that a value femu cannot use is found
    /// when the pipeline is checked, at the card that holds it.
    fn check_elements(&self, model: &Model, origins: &Origins) -> Result<(), NastranError> {
        for (id, e) in &model.elements {
            let Err(err) = crate::fe::model_assembly::element_matrices(
                model,
                e,
                crate::fe::element::MassKind::Consistent,
            ) else {
                continue;
            };
            let loc = origins.elements.get(id).cloned().unwrap_or(Loc {
                file: self.top_file.clone(),
                line: 0,
                card: Rc::from("element"),
            });
            return Err(NastranError::Element {
                file: loc.file.to_string().into(),
                line: loc.line,
                card: loc.card.to_string().into(),
                id: *id,
                uses: self.element_uses(model, e).into(),
                message: err.to_string().into(),
            });
        }
        Ok(())
    }

    /// ` (property P at …, material M at …)` for an element's message, empty without a property.
    fn element_uses(&self, model: &Model, e: &Element) -> String {
        let Some(p) = e.property() else {
            return String::new();
        };
        let mid = model
            .shell_properties
            .get(&p)
            .map(|s| s.material)
            .or_else(|| model.beam_properties.get(&p).map(|b| b.material));
        let at = |l: Option<&Loc>| l.map_or(String::new(), |l| format!(" at {}", l.place()));
        let mat = mid.map_or(String::new(), |m| {
            format!(", material {m}{}", at(self.materials.get(&m).map(|x| &x.0)))
        });
        format!(" (property {p}{}{mat})", at(self.pids.get(&p)))
    }
}

/// A beam's orientation vector: X1–X3 as given, or from GA towards G0; refused when zero or
/// parallel to the axis, or when the grids coincide.
fn beam_orientation(
    model: &Model,
    loc: &Loc,
    nodes: [u64; 2],
    orient: Orient,
) -> Result<[f64; 3], NastranError> {
    let orientation = match orient {
        Orient::Vector(v) => v,
        Orient::G0(g0) => {
            let (Some(a), Some(p)) = (model.nodes.get(&nodes[0]), model.nodes.get(&g0)) else {
                return Err(loc.field_err(
                    5,
                    "G0",
                    format!(
                        "orientation grid {g0} or end grid {} is not defined",
                        nodes[0]
                    ),
                    "G0 must be a GRID of the deck",
                ));
            };
            sub(*p, *a)
        }
    };
    if let (Some(a), Some(b)) = (model.nodes.get(&nodes[0]), model.nodes.get(&nodes[1])) {
        let axis = sub(*b, *a);
        if norm(axis) == 0.0 {
            return Err(loc.field_err(
                4,
                "GB",
                format!("grids {} and {} coincide (zero length)", nodes[0], nodes[1]),
                "a beam needs two grids at different points",
            ));
        }
        if norm(cross(axis, orientation)) <= 1e-9 * norm(axis) * norm(orientation) {
            return Err(loc.field_err(
                5,
                "X1/G0",
                format!("orientation vector {orientation:?} is zero or parallel to the axis"),
                "a vector (or G0 direction) that is not parallel to GA->GB",
            ));
        }
    }
    Ok(orientation)
}
