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
        // Before the rigid elements are resolved (which takes what the case control said).
        let eigen_request = self.eigen_request()?;
        let mut model = Model::default();
        let mut origins = Origins::default();
        let geo = self.geometry()?;
        self.place_grids(&mut model, &geo)?;
        self.place_scalar_points(&mut model)?;
        for (id, m) in &self.materials {
            model.materials.insert(*id, m.1.clone());
        }
        model.shell_properties = std::mem::take(&mut self.shells);
        self.finish_laminates(&mut model, &geo)?;
        model.beam_properties = std::mem::take(&mut self.beams);
        self.check_rod_properties()?;
        model.rod_properties = std::mem::take(&mut self.rods);
        model.solid_properties = self.resolve_solid_properties(&geo)?;
        model.anisotropic_materials = self.mat9s.iter().map(|(k, v)| (*k, v.1.clone())).collect();
        for (id, (loc, e)) in std::mem::take(&mut self.elements) {
            let element = self.resolve_element(&model, &geo, &loc, e)?;
            model.elements.insert(id, element);
            origins.elements.insert(id, loc);
        }
        self.scalar_constraints()?;
        self.resolve_constraints(&mut model, &mut origins)?;
        self.resolve_rigid(&mut model, &geo)?;
        self.resolve_sets(&mut model, &mut origins, set_names)?;
        for (loc, p) in parameters {
            origins.parameters.push((p.name.clone(), loc));
            model.parameters.push(p);
        }
        if let Some((_, w)) = &self.wtmass {
            apply_wtmass(&mut model, *w);
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
        let grdpnt = match &self.grdpnt {
            None => None,
            Some((_, 0)) => Some([0.0; 3]),
            Some((loc, g)) => Some(*model.nodes.get(g).ok_or_else(|| {
                loc.field_err(
                    2,
                    "V1",
                    format!("grid {g} is not defined"),
                    "the reference grid of the weight summary: a GRID id, 0 for the basic origin, or -1 for none",
                )
            })?),
        };
        Ok(BulkImport {
            grdpnt,
            eigen_request,
            model,
            unknown,
            skipped: self.skipped,
            ignored: self.ignored,
            warnings: self.warnings,
            source_digest: String::new(),
        })
    }

    /// Grid points in the basic system, the displacement systems of those whose CD axes are not
    /// the basic ones; PS components (in the grid's CD system) become constraints.
    fn place_grids(&mut self, model: &mut Model, geo: &Geometry) -> Result<(), NastranError> {
        let mut ps = Vec::new();
        for (&id, g) in &self.grids {
            model.nodes.insert(id, geo.positions[&id]);
            let cd = self.grid_cd(g);
            if cd != 0 && !geo.frames.contains_key(&cd) {
                let loc = match (g.cd, &self.grdset) {
                    (None, Some(d)) => &d.loc,
                    _ => &g.loc,
                };
                return Err(loc.field_err(
                    6,
                    "CD",
                    format!("coordinate system {cd} is not defined in the deck"),
                    "0 or blank (basic) or the id of a CORD1R/C/S or CORD2R/C/S card",
                ));
            }
            if let (_, Some(dirs)) = self.grid_directions(geo, id)
                && dirs != IDENTITY
            {
                model.displacement_systems.insert(id, dirs);
            }
            for &comp in self.grid_ps(g) {
                ps.push((g.loc.clone(), None, DofId::new(id, comp)));
            }
        }
        self.spcs.extend(ps);
        Ok(())
    }

    /// An element as the model holds it, its references to other cards resolved.
    fn resolve_element(
        &self,
        model: &Model,
        geo: &Geometry,
        loc: &Loc,
        e: ElemIn,
    ) -> Result<Element, NastranError> {
        Ok(match e {
            ElemIn::Done(e) => e,
            ElemIn::Beam {
                eid,
                beam,
                nodes,
                property,
                orient,
                ends,
            } => self.beam_in_basic(model, geo, loc, nodes, (eid, beam), property, orient, ends)?,
            ElemIn::Scalar(e) => self.resolve_scalar(model, geo, loc, e)?,
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
            ElemIn::MassInSystem {
                node,
                mass,
                inertia,
                offset,
                cid,
            } => {
                let (Some(frame), Some(at)) = (geo.frames.get(&cid), model.nodes.get(&node)) else {
                    return Err(loc.field_err(
                        3,
                        "CID",
                        format!("coordinate system {cid} is not defined in the deck"),
                        "0 (basic), -1, or the id of a CORD1R/C/S or CORD2R/C/S card",
                    ));
                };
                let d = frame.directions_at(*at);
                Element::Mass {
                    node,
                    mass,
                    inertia: rotate_inertia(&d, inertia),
                    offset: combine(&d, offset),
                }
            }
        })
    }

    /// SPC1 THRU ranges over the grids that exist, merged with SPC and PS into one sorted list
    /// of DOFs (components of each grid's displacement system, as Nastran constrains them).
    fn resolve_constraints(
        &mut self,
        model: &mut Model,
        origins: &mut Origins,
    ) -> Result<(), NastranError> {
        let selected = self.selected_spc_sets()?;
        let chosen = |sid: &Option<u64>| match (sid, &selected) {
            (None, _) | (_, None) => true,
            (Some(s), Some(set)) => set.contains(s),
        };
        for (loc, sid, comps, lo, hi) in &self.spc_ranges {
            if !chosen(&Some(*sid)) {
                continue;
            }
            for &g in model.nodes.range(lo..=hi).map(|(g, _)| g) {
                for &comp in comps {
                    self.spcs
                        .push((loc.clone(), Some(*sid), DofId::new(g, comp)));
                }
            }
        }
        let mut by_grid: BTreeMap<u64, (Loc, BTreeSet<Component>)> = BTreeMap::new();
        for (loc, _, d) in self.spcs.iter().filter(|(_, sid, _)| chosen(sid)) {
            by_grid
                .entry(d.node)
                .or_insert_with(|| (loc.clone(), BTreeSet::new()))
                .1
                .insert(d.comp);
        }
        let mut constraints = Vec::new();
        for (g, (loc, comps)) in by_grid {
            // Components of the grid's displacement system, as the model's DOFs are.
            constraints.extend(comps.iter().map(|&c| DofId::new(g, c)));
            origins.constraints.insert(g, loc);
        }
        constraints.sort();
        constraints.dedup();
        model.constraints = constraints;
        Ok(())
    }

    /// The SPC/SPC1 set ids in force: those the case control's `SPC = n` selects (through an
    /// SPCADD or directly), or `None` (all of them) for a deck without case control, with a
    /// warning when it holds several.
    fn selected_spc_sets(&mut self) -> Result<Option<BTreeSet<u64>>, NastranError> {
        let Some((loc, sid)) = self.case_control.first().cloned() else {
            if self.spc_sids.len() > 1 {
                let sids: Vec<String> = self.spc_sids.iter().map(u64::to_string).collect();
                self.warnings.push(format!(
                    "{}: SPC/SPC1 sets {} are merged into one constraint list (the deck has no case control `SPC = n` to choose one)",
                    self.top_file,
                    sids.join(", ")
                ));
            }
            return Ok(None);
        };
        let others: BTreeSet<u64> = self.case_control.iter().map(|(_, s)| *s).collect();
        if others.len() > 1 {
            let list: Vec<String> = others.iter().map(u64::to_string).collect();
            self.warnings.push(format!(
                "{} line {}: the case control selects SPC sets {}; femu builds one model, with SPC = {sid}, the first selection",
                loc.file,
                loc.line,
                list.join(", ")
            ));
        }
        let members = match self.spcadds.get(&sid) {
            Some((add, members)) => {
                if let Some(m) = members.iter().find(|m| !self.spc_sids.contains(m)) {
                    return Err(NastranError::Syntax {
                        file: add.file.to_string().into(),
                        line: add.line,
                        problem: format!(
                            "SPCADD {sid} lists set {m}, which no SPC or SPC1 card defines"
                        )
                        .into(),
                        valid: "the set ids of SPC or SPC1 cards of the deck".into(),
                    });
                }
                members.iter().copied().collect()
            }
            None if self.spc_sids.contains(&sid) => BTreeSet::from([sid]),
            None => {
                return Err(NastranError::Syntax {
                    file: loc.file.to_string().into(),
                    line: loc.line,
                    problem: format!("the case control selects SPC = {sid}, which no SPC, SPC1 or SPCADD card defines").into(),
                    valid: "the set id of an SPC, SPC1 or SPCADD card of the bulk data".into(),
                });
            }
        };
        Ok(Some(members))
    }

    /// An orientation vector X1–X3 is given in the displacement system of GA (QRG CBAR/CBEAM).
    pub(super) fn orient_in_basic(&self, geo: &Geometry, ga: u64, orient: Orient) -> Orient {
        match orient {
            Orient::Vector(v) => match self.grid_directions(geo, ga).1 {
                Some(d) => Orient::Vector(combine(&d, v)),
                None => Orient::Vector(v),
            },
            g0 => g0,
        }
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
            ModelError::MissingElementMaterial { element, material } => (
                origins.elements.get(element).cloned(),
                format!("add MAT1 {material}"),
            ),
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
            ModelError::ScalarPointIsGrid(_) | ModelError::ComponentMismatch { .. } => (
                None,
                "grid components are 1-6, a scalar point's 0 or blank; ids are unique".to_string(),
            ),
            ModelError::ConstraintNode(node) => (
                origins.constraints.get(node).cloned(),
                format!("add GRID {node} or remove it from the SPC/SPC1"),
            ),
            ModelError::BadDisplacementSystem { node, .. } => (
                self.grids.get(node).map(|g| g.loc.clone()),
                "a CD naming a coordinate system defined by a CORD card".to_string(),
            ),
            ModelError::MpcNode { .. }
            | ModelError::MpcDependentTwice { .. }
            | ModelError::MpcConstrained { .. }
            | ModelError::MpcCycle { .. } => (
                None,
                "correct the rigid elements and MPC cards named".to_string(),
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
            let Err(err) = crate::fe::model_assembly::element_matrices_with_id(
                model,
                *id,
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
            .or_else(|| model.beam_properties.get(&p).map(|b| b.material))
            .or_else(|| model.rod_properties.get(&p).map(|r| r.material))
            .or_else(|| model.solid_properties.get(&p).map(|r| r.material));
        let at = |l: Option<&Loc>| l.map_or(String::new(), |l| format!(" at {}", l.place()));
        let mat = mid.map_or(String::new(), |m| {
            let loc = self.materials.get(&m).map(|x| &x.0);
            format!(
                ", material {m}{}",
                at(loc.or(self.mat9s.get(&m).map(|x| &x.0)))
            )
        });
        format!(" (property {p}{}{mat})", at(self.pids.get(&p)))
    }
}

/// A beam's orientation vector: X1–X3 as given, or from GA towards G0; refused when zero or
/// parallel to the axis, or when the grids coincide.
pub(super) fn beam_orientation(
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

/// The basic axes as a displacement system.
const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// CONM2 inertia `[I11, I21, I22, I31, I32, I33]` given along local axes `d` (rows, basic), as
/// the same six numbers along the basic axes: `J_b = Dᵀ J D` with `J = [[I11, −I21, −I31], …]`
/// (the QRG's sign convention for the products of inertia).
fn rotate_inertia(d: &[[f64; 3]; 3], i: [f64; 6]) -> [f64; 6] {
    let [i11, i21, i22, i31, i32, i33] = i;
    let j = [[i11, -i21, -i31], [-i21, i22, -i32], [-i31, -i32, i33]];
    let mut b = [[0.0; 3]; 3];
    for (r, row) in b.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = (0..3)
                .flat_map(|k| (0..3).map(move |l| (k, l)))
                .map(|(k, l)| d[k][r] * j[k][l] * d[l][c])
                .sum();
        }
    }
    [b[0][0], -b[1][0], b[1][1], -b[2][0], -b[2][1], b[2][2]]
}

/// PARAM,WTMASS: every mass input — densities, non-structural masses, lumped masses and
/// inertias — times `w`, so that the mass matrix is `w` times the one the deck's numbers give,
/// as Nastran forms it.
fn apply_wtmass(model: &mut Model, w: f64) {
    for m in model.materials.values_mut() {
        m.rho *= w;
    }
    for m in model.anisotropic_materials.values_mut() {
        m.rho *= w;
    }
    for p in model.shell_properties.values_mut() {
        p.nsm *= w;
    }
    for p in model.beam_properties.values_mut() {
        p.nsm *= w;
        if let Some(c) = &mut p.centres {
            c.nsi *= w;
        }
    }
    for p in model.rod_properties.values_mut() {
        p.nsm *= w;
    }
    for e in model.elements.values_mut() {
        super::scalars::wtmass_scalars(e, w);
        if let Element::Mass { mass, inertia, .. } = e {
            *mass *= w;
            for i in inertia.iter_mut() {
                *i *= w;
            }
        }
        if let Element::Rod {
            section: crate::model::structure::RodSection::Own(p),
            ..
        } = e
        {
            p.nsm *= w;
        }
    }
}
