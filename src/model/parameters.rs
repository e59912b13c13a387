//! Reading and writing the value of an updating parameter (docs/theory.md §2, 2.16): a parameter is
//! one property of the elements of its set, so its value is that property's value, which must be
//! the same on every element of the set. Writing a value gives the set its own copies of shared
//! properties and materials first, so elements outside the set never change with it; the
//! connectivity never changes.

use super::structure::{BeamSection, Element, Model, Parameter, ParameterKind, RodSection};
use crate::core::Component;

/// Why a parameter's value could not be read or written.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParameterValueError {
    /// The set does not exist.
    #[error("parameter `{parameter}`: set `{set}` is not a set of the model (sets: {known})")]
    MissingSet {
        /// Parameter name.
        parameter: String,
        /// Set name.
        set: String,
        /// Known sets.
        known: String,
    },
    /// The set holds no element the parameter acts on.
    #[error("parameter `{parameter}` ({kind:?}): set `{set}` holds no element it can act on")]
    EmptySet {
        /// Parameter name.
        parameter: String,
        /// What it changes.
        kind: ParameterKind,
        /// Set name.
        set: String,
    },
    /// An element of the set does not carry this kind of parameter.
    #[error(
        "parameter `{parameter}` ({kind:?}) cannot act on element {element} ({element_kind}) of set `{set}`"
    )]
    NotApplicable {
        /// Parameter name.
        parameter: String,
        /// What it changes.
        kind: ParameterKind,
        /// Set name.
        set: String,
        /// Element id.
        element: u64,
        /// Element type.
        element_kind: &'static str,
    },
    /// The set's elements hold different values, so the parameter has none.
    #[error(
        "parameter `{parameter}` ({kind:?}) has no single value: element {first} of set `{set}` holds {first_value:e}, element {other} holds {other_value:e}; split the set so each holds one value"
    )]
    NotUniform {
        /// Parameter name.
        parameter: String,
        /// What it changes.
        kind: ParameterKind,
        /// Set name.
        set: String,
        /// First element.
        first: u64,
        /// Its value.
        first_value: f64,
        /// An element with another value.
        other: u64,
        /// Its value.
        other_value: f64,
    },
    /// A value outside what the property allows.
    #[error("parameter `{parameter}`: value {value:e} is not a positive finite number")]
    BadValue {
        /// Parameter name.
        parameter: String,
        /// The value.
        value: f64,
    },
    /// A reference of the model is broken.
    #[error("parameter `{parameter}`: element {element} refers to a missing property or material")]
    Broken {
        /// Parameter name.
        parameter: String,
        /// Element id.
        element: u64,
    },
}

impl crate::core::InputFault for ParameterValueError {
    fn is_input(&self) -> bool {
        true
    }
}

/// Where a parameter's value lives for one element.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    ShellThickness(u64),
    ShellMaterial(u64, Field),
    BeamMaterial(u64, Field),
    /// A rod's material, by element id (through its property or its own CONROD section).
    RodMaterial(u64, Field),
    /// A solid's material, by solid property id (MAT1 `E`, `ρ`; MAT9 `ρ`).
    SolidMaterial(u64, Field),
    BeamDim(u64, Dim),
    Bush(u64, usize),
    Scalar(u64),
    /// A scalar mass (CMASS) by element id.
    ScalarMass(u64),
    Mass(u64),
    Inertia(u64, usize),
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Field {
    E,
    Rho,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Dim {
    Width,
    Height,
}

impl Model {
    /// Each element of the parameter's set with where its value lives.
    fn slots(&self, p: &Parameter) -> Result<Vec<(u64, Slot)>, ParameterValueError> {
        let ids = self
            .sets
            .get(&p.set)
            .ok_or_else(|| ParameterValueError::MissingSet {
                parameter: p.name.clone(),
                set: p.set.clone(),
                known: self.sets.keys().cloned().collect::<Vec<_>>().join(", "),
            })?;
        let mut out = Vec::with_capacity(ids.len());
        for &id in ids {
            let broken = || ParameterValueError::Broken {
                parameter: p.name.clone(),
                element: id,
            };
            let e = self.elements.get(&id).ok_or_else(broken)?;
            let not_applicable = || ParameterValueError::NotApplicable {
                parameter: p.name.clone(),
                kind: p.kind.clone(),
                set: p.set.clone(),
                element: id,
                element_kind: e.type_name(),
            };
            let slot = match (e, &p.kind) {
                (
                    Element::Quad4 { property, .. }
                    | Element::Tria3 { property, .. }
                    | Element::Quad8 { property, .. }
                    | Element::Tria6 { property, .. },
                    kind,
                ) => match kind {
                    ParameterKind::ShellThickness => Slot::ShellThickness(*property),
                    ParameterKind::YoungsModulus => Slot::ShellMaterial(*property, Field::E),
                    ParameterKind::Density => Slot::ShellMaterial(*property, Field::Rho),
                    _ => return Err(not_applicable()),
                },
                (Element::Beam { property, .. }, kind) => match kind {
                    ParameterKind::YoungsModulus => Slot::BeamMaterial(*property, Field::E),
                    ParameterKind::Density => Slot::BeamMaterial(*property, Field::Rho),
                    ParameterKind::BeamWidth | ParameterKind::BeamHeight => {
                        let bp = self.beam_properties.get(property).ok_or_else(broken)?;
                        let BeamSection::Rectangle { .. } = bp.section else {
                            return Err(not_applicable());
                        };
                        if p.kind == ParameterKind::BeamWidth {
                            Slot::BeamDim(*property, Dim::Width)
                        } else {
                            Slot::BeamDim(*property, Dim::Height)
                        }
                    }
                    _ => return Err(not_applicable()),
                },
                (Element::Rod { .. }, ParameterKind::YoungsModulus) => {
                    Slot::RodMaterial(id, Field::E)
                }
                (Element::Rod { .. }, ParameterKind::Density) => Slot::RodMaterial(id, Field::Rho),
                (Element::Solid { property, .. }, ParameterKind::YoungsModulus) => {
                    // Only an isotropic (MAT1) material has one modulus.
                    let sp = self.solid_properties.get(property).ok_or_else(broken)?;
                    if !self.materials.contains_key(&sp.material) {
                        return Err(not_applicable());
                    }
                    Slot::SolidMaterial(*property, Field::E)
                }
                (Element::Solid { property, .. }, ParameterKind::Density) => {
                    Slot::SolidMaterial(*property, Field::Rho)
                }
                (Element::Bush { .. }, ParameterKind::SpringStiffness(c)) if !c.is_scalar() => {
                    Slot::Bush(id, c.slot())
                }
                (Element::ScalarSpring { .. }, ParameterKind::SpringStiffness(_)) => {
                    Slot::Scalar(id)
                }
                (Element::Mass { .. }, ParameterKind::LumpedMass(c)) => match c {
                    Component::Ux | Component::Uy | Component::Uz => Slot::Mass(id),
                    Component::Rx => Slot::Inertia(id, 0),
                    Component::Ry => Slot::Inertia(id, 2),
                    Component::Rz => Slot::Inertia(id, 5),
                    Component::Scalar => return Err(not_applicable()),
                },
                (Element::ScalarMass { .. }, ParameterKind::LumpedMass(_)) => Slot::ScalarMass(id),
                _ => return Err(not_applicable()),
            };
            out.push((id, slot));
        }
        if out.is_empty() {
            return Err(ParameterValueError::EmptySet {
                parameter: p.name.clone(),
                kind: p.kind.clone(),
                set: p.set.clone(),
            });
        }
        Ok(out)
    }

    fn slot_value(&self, slot: Slot) -> Option<f64> {
        let material = |id: u64, f: Field| {
            self.materials
                .get(&id)
                .map(|m| match f {
                    Field::E => m.e,
                    Field::Rho => m.rho,
                })
                .or_else(|| {
                    self.shell_materials.get(&id).map(|m| match f {
                        Field::E => m.modulus(),
                        Field::Rho => m.rho(),
                    })
                })
        };
        match slot {
            Slot::ShellThickness(pid) => self.shell_properties.get(&pid).map(|p| p.thickness),
            Slot::ShellMaterial(pid, f) => material(self.shell_properties.get(&pid)?.material, f),
            Slot::BeamMaterial(pid, f) => material(self.beam_properties.get(&pid)?.material, f),
            Slot::RodMaterial(id, f) => material(self.rod_material(id)?, f),
            Slot::SolidMaterial(pid, f) => {
                let mid = self.solid_properties.get(&pid)?.material;
                match (self.anisotropic_materials.get(&mid), f) {
                    (Some(m), Field::Rho) => Some(m.rho),
                    (Some(_), Field::E) => None,
                    (None, f) => material(mid, f),
                }
            }
            Slot::BeamDim(pid, d) => match self.beam_properties.get(&pid)?.section {
                BeamSection::Rectangle { width, height } => Some(match d {
                    Dim::Width => width,
                    Dim::Height => height,
                }),
                _ => None,
            },
            Slot::Bush(id, c) => match self.elements.get(&id)? {
                Element::Bush { k, .. } => Some(k[c]),
                _ => None,
            },
            Slot::Scalar(id) => match self.elements.get(&id)? {
                Element::ScalarSpring { k, .. } => Some(*k),
                _ => None,
            },
            Slot::ScalarMass(id) => match self.elements.get(&id)? {
                Element::ScalarMass { m, .. } => Some(*m),
                _ => None,
            },
            Slot::Mass(id) => match self.elements.get(&id)? {
                Element::Mass { mass, .. } => Some(*mass),
                _ => None,
            },
            Slot::Inertia(id, c) => match self.elements.get(&id)? {
                Element::Mass { inertia, .. } => Some(inertia[c]),
                _ => None,
            },
        }
    }

    /// The value of a parameter: its property on the set's elements, which must agree.
    pub fn parameter_value(&self, p: &Parameter) -> Result<f64, ParameterValueError> {
        let slots = self.slots(p)?;
        let mut first: Option<(u64, f64)> = None;
        for (id, slot) in slots {
            let v = self
                .slot_value(slot)
                .ok_or_else(|| ParameterValueError::Broken {
                    parameter: p.name.clone(),
                    element: id,
                })?;
            match first {
                None => first = Some((id, v)),
                Some((f, fv)) if (v - fv).abs() > 1e-12 * fv.abs() => {
                    return Err(ParameterValueError::NotUniform {
                        parameter: p.name.clone(),
                        kind: p.kind.clone(),
                        set: p.set.clone(),
                        first: f,
                        first_value: fv,
                        other: id,
                        other_value: v,
                    });
                }
                Some(_) => {}
            }
        }
        Ok(first.map(|f| f.1).unwrap_or(0.0))
    }

    /// Sets a parameter's value on every element of its set. Properties (and, for `E` and `ρ`,
    /// materials) that the set shares with other elements are copied under new ids first.
    pub fn set_parameter_value(
        &mut self,
        p: &Parameter,
        value: f64,
    ) -> Result<(), ParameterValueError> {
        if !(value.is_finite() && value > 0.0) {
            return Err(ParameterValueError::BadValue {
                parameter: p.name.clone(),
                value,
            });
        }
        let slots = self.slots(p)?;
        let in_set: std::collections::BTreeSet<u64> = slots.iter().map(|s| s.0).collect();
        let shell = matches!(
            slots[0].1,
            Slot::ShellThickness(_) | Slot::ShellMaterial(..)
        );
        let beam = matches!(slots[0].1, Slot::BeamMaterial(..) | Slot::BeamDim(..));
        if shell || beam {
            self.own_properties(&in_set, shell);
        }
        if matches!(slots[0].1, Slot::ShellMaterial(..) | Slot::BeamMaterial(..)) {
            self.own_materials(&in_set, shell);
        }
        if matches!(slots[0].1, Slot::RodMaterial(..)) {
            self.own_rod_materials(&in_set);
        }
        if matches!(slots[0].1, Slot::SolidMaterial(..)) {
            self.own_solid_materials(&in_set);
        }
        // Slots again: the property ids may have changed.
        for (id, slot) in self.slots(p)? {
            let broken = || ParameterValueError::Broken {
                parameter: p.name.clone(),
                element: id,
            };
            match slot {
                Slot::ShellThickness(pid) => {
                    self.shell_properties
                        .get_mut(&pid)
                        .ok_or_else(broken)?
                        .set_thickness(value);
                }
                Slot::ShellMaterial(pid, f) | Slot::BeamMaterial(pid, f) => {
                    let mid = if shell {
                        self.shell_properties.get(&pid).map(|p| p.material)
                    } else {
                        self.beam_properties.get(&pid).map(|p| p.material)
                    }
                    .ok_or_else(broken)?;
                    if let Some(m) = self.shell_materials.get_mut(&mid).filter(|_| shell) {
                        // MAT8/MAT2: every modulus in proportion (see `ShellMaterial`).
                        match f {
                            Field::E => m.set_modulus(value),
                            Field::Rho => *m.rho_mut() = value,
                        }
                        continue;
                    }
                    let m = self.materials.get_mut(&mid).ok_or_else(broken)?;
                    match f {
                        Field::E => m.e = value,
                        Field::Rho => m.rho = value,
                    }
                }
                Slot::RodMaterial(_, f) => {
                    let mid = self.rod_material(id).ok_or_else(broken)?;
                    let m = self.materials.get_mut(&mid).ok_or_else(broken)?;
                    match f {
                        Field::E => m.e = value,
                        Field::Rho => m.rho = value,
                    }
                }
                Slot::SolidMaterial(pid, f) => {
                    let mid = self.solid_properties.get(&pid).ok_or_else(broken)?.material;
                    if let Some(m) = self.anisotropic_materials.get_mut(&mid) {
                        m.rho = value;
                    } else {
                        let m = self.materials.get_mut(&mid).ok_or_else(broken)?;
                        match f {
                            Field::E => m.e = value,
                            Field::Rho => m.rho = value,
                        }
                    }
                }
                Slot::BeamDim(pid, d) => {
                    let bp = self.beam_properties.get_mut(&pid).ok_or_else(broken)?;
                    if let BeamSection::Rectangle { width, height } = &mut bp.section {
                        // A tapered BAR (PBEAML stations): the value is end A's, and the
                        // dimension scales at every station in proportion.
                        let (slot, i) = match d {
                            Dim::Width => (width, 0),
                            Dim::Height => (height, 1),
                        };
                        let ratio = value / *slot;
                        *slot = value;
                        for st in bp.taper.iter_mut().flat_map(|t| t.stations.iter_mut()) {
                            if let Some(v) = st.values.get_mut(i) {
                                *v = if st.x == 0.0 { value } else { *v * ratio };
                            }
                        }
                    }
                }
                Slot::Bush(_, c) => {
                    if let Some(Element::Bush { k, .. }) = self.elements.get_mut(&id) {
                        k[c] = value;
                    }
                }
                Slot::Scalar(_) => {
                    if let Some(Element::ScalarSpring { k, .. }) = self.elements.get_mut(&id) {
                        *k = value;
                    }
                }
                Slot::ScalarMass(_) => {
                    if let Some(Element::ScalarMass { m, .. }) = self.elements.get_mut(&id) {
                        *m = value;
                    }
                }
                Slot::Mass(_) => {
                    if let Some(Element::Mass { mass, .. }) = self.elements.get_mut(&id) {
                        *mass = value;
                    }
                }
                Slot::Inertia(_, c) => {
                    if let Some(Element::Mass { inertia, .. }) = self.elements.get_mut(&id) {
                        inertia[c] = value;
                    }
                }
            }
        }
        Ok(())
    }

    /// Gives the elements of `in_set` property ids no element outside the set uses.
    fn own_properties(&mut self, in_set: &std::collections::BTreeSet<u64>, shell: bool) {
        let mut outside = std::collections::BTreeSet::new();
        for (id, e) in &self.elements {
            if !in_set.contains(id)
                && let Some(pid) = e.property()
            {
                outside.insert(pid);
            }
        }
        let mut next = self
            .shell_properties
            .keys()
            .chain(self.beam_properties.keys())
            .chain(self.rod_properties.keys())
            .chain(self.solid_properties.keys())
            .max()
            .copied()
            .unwrap_or(0)
            + 1;
        let mut renamed = std::collections::BTreeMap::new();
        for id in in_set {
            let Some(e) = self.elements.get_mut(id) else {
                continue;
            };
            let property = match e {
                Element::Quad4 { property, .. }
                | Element::Tria3 { property, .. }
                | Element::Quad8 { property, .. }
                | Element::Tria6 { property, .. }
                    if shell =>
                {
                    property
                }
                Element::Beam { property, .. } if !shell => property,
                _ => continue,
            };
            if !outside.contains(property) {
                continue;
            }
            let new = *renamed.entry(*property).or_insert_with(|| {
                let n = next;
                next += 1;
                n
            });
            if shell {
                if let Some(p) = self.shell_properties.get(property).cloned() {
                    self.shell_properties.insert(new, p);
                }
            } else if let Some(p) = self.beam_properties.get(property).cloned() {
                self.beam_properties.insert(new, p);
            }
            *property = new;
        }
    }

    /// The material of rod `id` (through its property or its own section).
    fn rod_material(&self, id: u64) -> Option<u64> {
        match self.elements.get(&id)? {
            Element::Rod {
                section: RodSection::Property(pid),
                ..
            } => self.rod_properties.get(pid).map(|p| p.material),
            Element::Rod {
                section: RodSection::Own(p),
                ..
            } => Some(p.material),
            _ => None,
        }
    }

    /// Materials of the rods outside `in_set` (a shared rod property counts as outside when
    /// any of its rods is).
    fn rod_materials_outside(
        &self,
        in_set: &std::collections::BTreeSet<u64>,
    ) -> std::collections::BTreeSet<u64> {
        self.elements
            .iter()
            .filter(|(id, e)| !in_set.contains(id) && matches!(e, Element::Rod { .. }))
            .filter_map(|(id, _)| self.rod_material(*id))
            .collect()
    }

    /// The property ids of the elements outside `in_set`, and the first property id above every
    /// property of the model (for copies).
    fn properties_outside(
        &self,
        in_set: &std::collections::BTreeSet<u64>,
    ) -> (std::collections::BTreeSet<u64>, u64) {
        let mut outside = std::collections::BTreeSet::new();
        for (id, e) in &self.elements {
            if let (false, Some(pid)) = (in_set.contains(id), e.property()) {
                outside.insert(pid);
            }
        }
        let next = self
            .shell_properties
            .keys()
            .chain(self.beam_properties.keys())
            .chain(self.rod_properties.keys())
            .chain(self.solid_properties.keys())
            .max()
            .copied()
            .unwrap_or(0)
            + 1;
        (outside, next)
    }

    /// Gives the rods of `in_set` materials (and rod properties) that nothing outside the set
    /// uses: a rod property shared with rods outside is copied under a new id, then every
    /// material the set's rods share with any other element or property is copied.
    fn own_rod_materials(&mut self, in_set: &std::collections::BTreeSet<u64>) {
        use std::collections::{BTreeMap, BTreeSet};
        let (pid_outside, mut next_pid) = self.properties_outside(in_set);
        let mut renamed: BTreeMap<u64, u64> = BTreeMap::new();
        for id in in_set {
            let Some(Element::Rod {
                section: RodSection::Property(pid),
                ..
            }) = self.elements.get_mut(id)
            else {
                continue;
            };
            if !pid_outside.contains(pid) {
                continue;
            }
            let new = *renamed.entry(*pid).or_insert_with(|| {
                next_pid += 1;
                next_pid - 1
            });
            if let Some(p) = self.rod_properties.get(pid).cloned() {
                self.rod_properties.insert(new, p);
            }
            *pid = new;
        }
        // Materials used by anything outside the set's rods.
        let mut outside = self.rod_materials_outside(in_set);
        for p in self.shell_properties.values() {
            outside.extend(p.material_ids());
        }
        outside.extend(self.beam_properties.values().map(|p| p.material));
        outside.extend(self.solid_properties.values().map(|p| p.material));
        let own_pids: BTreeSet<u64> = in_set
            .iter()
            .filter_map(|id| match self.elements.get(id) {
                Some(Element::Rod {
                    section: RodSection::Property(pid),
                    ..
                }) => Some(*pid),
                _ => None,
            })
            .collect();
        for (pid, p) in &self.rod_properties {
            if !own_pids.contains(pid) {
                outside.insert(p.material);
            }
        }
        let mut next = self
            .materials
            .keys()
            .chain(self.anisotropic_materials.keys())
            .chain(self.shell_materials.keys())
            .max()
            .copied()
            .unwrap_or(0)
            + 1;
        let mut copies: BTreeMap<u64, u64> = BTreeMap::new();
        let mut copy = |materials: &mut BTreeMap<u64, crate::model::Material>, mid: &mut u64| {
            if !outside.contains(mid) {
                return;
            }
            let new = *copies.entry(*mid).or_insert_with(|| {
                next += 1;
                next - 1
            });
            if let Some(m) = materials.get(mid).cloned() {
                materials.insert(new, m);
            }
            *mid = new;
        };
        for pid in &own_pids {
            if let Some(p) = self.rod_properties.get_mut(pid) {
                copy(&mut self.materials, &mut p.material);
            }
        }
        for id in in_set {
            if let Some(Element::Rod {
                section: RodSection::Own(p),
                ..
            }) = self.elements.get_mut(id)
            {
                copy(&mut self.materials, &mut p.material);
            }
        }
    }

    /// Gives the solids of `in_set` solid properties and materials (MAT1 or MAT9) that nothing
    /// outside the set uses: a shared solid property is copied under a new id, then every
    /// material the set's properties share with any other property or element is copied.
    fn own_solid_materials(&mut self, in_set: &std::collections::BTreeSet<u64>) {
        use std::collections::{BTreeMap, BTreeSet};
        let (pid_outside, mut next_pid) = self.properties_outside(in_set);
        let mut renamed: BTreeMap<u64, u64> = BTreeMap::new();
        let mut own_pids = BTreeSet::new();
        for id in in_set {
            let Some(Element::Solid { property, .. }) = self.elements.get_mut(id) else {
                continue;
            };
            if pid_outside.contains(property) {
                let new = *renamed.entry(*property).or_insert_with(|| {
                    next_pid += 1;
                    next_pid - 1
                });
                if let Some(p) = self.solid_properties.get(property).cloned() {
                    self.solid_properties.insert(new, p);
                }
                *property = new;
            }
            own_pids.insert(*property);
        }
        let mut outside = self.rod_materials_outside(&BTreeSet::new());
        for p in self.shell_properties.values() {
            outside.extend([p.material, p.bending_mid(), p.shear_mid()]);
        }
        outside.extend(self.beam_properties.values().map(|p| p.material));
        for (pid, p) in &self.solid_properties {
            if !own_pids.contains(pid) {
                outside.insert(p.material);
            }
        }
        let mut next = self
            .materials
            .keys()
            .chain(self.anisotropic_materials.keys())
            .max()
            .copied()
            .unwrap_or(0)
            + 1;
        let mut copies: BTreeMap<u64, u64> = BTreeMap::new();
        for pid in &own_pids {
            let Some(p) = self.solid_properties.get_mut(pid) else {
                continue;
            };
            if !outside.contains(&p.material) {
                continue;
            }
            let old = p.material;
            let new = *copies.entry(old).or_insert_with(|| {
                next += 1;
                next - 1
            });
            if let Some(m) = self.materials.get(&old).cloned() {
                self.materials.insert(new, m);
            }
            if let Some(m) = self.anisotropic_materials.get(&old).cloned() {
                self.anisotropic_materials.insert(new, m);
            }
            p.material = new;
        }
    }

    /// Gives the (now owned) properties of `in_set` material ids no other property uses.
    fn own_materials(&mut self, in_set: &std::collections::BTreeSet<u64>, shell: bool) {
        let own: std::collections::BTreeSet<u64> = in_set
            .iter()
            .filter_map(|id| self.elements.get(id)?.property())
            .collect();
        let mut outside = self.rod_materials_outside(&std::collections::BTreeSet::new());
        outside.extend(self.solid_properties.values().map(|p| p.material));
        for (pid, p) in &self.shell_properties {
            if !(shell && own.contains(pid)) {
                outside.insert(p.material);
            }
            // Another part's material is outside what the parameter (the `material`) changes.
            outside.extend(p.material_ids().into_iter().filter(|m| *m != p.material));
        }
        for (pid, p) in &self.beam_properties {
            if shell || !own.contains(pid) {
                outside.insert(p.material);
            }
        }
        let mut next = self
            .materials
            .keys()
            .chain(self.anisotropic_materials.keys())
            .chain(self.shell_materials.keys())
            .max()
            .copied()
            .unwrap_or(0)
            + 1;
        let mut renamed = std::collections::BTreeMap::new();
        for pid in own {
            let material = if shell {
                self.shell_properties.get_mut(&pid).map(|p| &mut p.material)
            } else {
                self.beam_properties.get_mut(&pid).map(|p| &mut p.material)
            };
            let Some(material) = material else { continue };
            if !outside.contains(material) {
                continue;
            }
            let new = *renamed.entry(*material).or_insert_with(|| {
                let n = next;
                next += 1;
                n
            });
            let old = *material;
            *material = new;
            if let Some(m) = self.materials.get(&old).cloned() {
                self.materials.insert(new, m);
            } else if let Some(m) = self.shell_materials.get(&old).cloned() {
                self.shell_materials.insert(new, m);
            }
            // A PSHELL part naming the same material (MID3 = MID1 with another MID2) follows it,
            // and so do a laminate's plies of it.
            if let Some(p) = self.shell_properties.get_mut(&pid).filter(|_| shell) {
                for part in [
                    &mut p.bending_material,
                    &mut p.shear_material,
                    &mut p.coupling_material,
                ] {
                    if *part == Some(old) {
                        *part = Some(new);
                    }
                }
                if let Some(l) = &mut p.laminate {
                    for ply in &mut l.plies {
                        if ply.material == old {
                            ply.material = new;
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::generate::{BentPlate, bent_plate};

    fn strip(name: &str, kind: ParameterKind) -> Parameter {
        Parameter {
            name: name.into(),
            kind,
            set: name.into(),
            lower: 1e-9,
            upper: 1e12,
        }
    }

    /// Writing one strip's thickness and modulus leaves every other element as it was.
    #[test]
    fn writing_a_value_touches_only_the_set() {
        let mut model = bent_plate(&BentPlate::default());
        let before = model.clone();
        let t = strip("strip_3", ParameterKind::ShellThickness);
        let e = strip("strip_3", ParameterKind::YoungsModulus);
        assert_eq!(model.parameter_value(&t).unwrap(), 1.4e-3);
        model.set_parameter_value(&t, 0.8e-3).unwrap();
        model.set_parameter_value(&e, 1.3 * 210e9).unwrap();
        assert_eq!(model.parameter_value(&t).unwrap(), 0.8e-3);
        assert!((model.parameter_value(&e).unwrap() - 1.3 * 210e9).abs() < 1.0);
        for name in ["strip_2", "strip_4", "plate_2"] {
            let other = strip(name, ParameterKind::ShellThickness);
            assert_eq!(model.parameter_value(&other).unwrap(), 1.4e-3, "{name}");
            let other = strip(name, ParameterKind::YoungsModulus);
            assert_eq!(
                model.parameter_value(&other).unwrap(),
                before.parameter_value(&other).unwrap()
            );
        }
        // Same nodes, same connectivity.
        assert_eq!(model.nodes, before.nodes);
        assert_eq!(model.elements.len(), before.elements.len());
        // A set spanning the changed strip now has two values.
        let plate = strip("plate_1", ParameterKind::ShellThickness);
        let err = model.parameter_value(&plate).unwrap_err();
        assert!(
            matches!(err, ParameterValueError::NotUniform { .. }),
            "{err}"
        );
    }

    #[test]
    fn a_kind_the_element_cannot_carry_is_named() {
        let model = bent_plate(&BentPlate::default());
        let err = model
            .parameter_value(&strip("strip_1", ParameterKind::BeamWidth))
            .unwrap_err();
        assert!(err.to_string().contains("cannot act on element"), "{err}");
        let err = model
            .parameter_value(&strip("strip_99", ParameterKind::Density))
            .unwrap_err();
        assert!(err.to_string().contains("strip_1"), "{err}");
    }
}
