//! Nastran bulk data import: reads a `.bdf`/`.dat` deck into a [`Model`].
//!
//! Field layouts follow the MSC Nastran Quick Reference Guide (QRG). Field numbers in messages
//! are the QRG's: 1–10 on each line of a card, with continuation lines counted from 1.
//!
//! Formats: small field (8 characters), large field (16 characters, `NAME*` and `*`
//! continuation half-lines), free field (commas; `NAME*,` for four fields per line), explicit
//! (`+name`/`*name`) and implicit (blank first field) continuations, `$` comments, `INCLUDE`
//! (quoted or bare, relative to the including file, quoted names may run over several lines,
//! cycles rejected), `BEGIN BULK` (anything before it is skipped when present; a later
//! `BEGIN SUPER`/`BEGIN AUXMODEL` section — a part superelement — is an error that lists every
//! such section with its line and size) and `ENDDATA` (anything after it is ignored), the real number shorthands `1.5-3`, `7.+4`, `.5`, `1+3`,
//! `1.E3` and `1D3`, and blank fields taking the QRG defaults.
//!
//! Cards read: GRID with GRDSET defaults, CORD1R/C/S and CORD2R/C/S (nested, in any order),
//! CQUAD4, CTRIA3, CQUADR, CTRIAR, CQUAD8, CTRIA6, CBAR, CBEAM (offsets, pin flags), BAROR, BEAMOR, CROD,
//! CONROD, CTUBE, CHEXA, CPENTA, CTETRA, CPYRAM with PSOLID and MAT9 (see below), PSHELL,
//! PCOMP, PCOMPG, PBAR, PBARL and PBEAML (the beam library, see below), PBEAM, PROD, PTUBE,
//! MAT1, MAT2, MAT8,
//! SPOINT, EPOINT, CELAS1–4 with PELAS, CMASS1–4 with PMASS, CDAMP1–4 with PDAMP, CVISC with
//! PVISC, CBUSH with PBUSH, CONM1, CONM2, SPC, SPC1, SPCADD, SET1, the rigid
//! elements RBE2, RBAR, RROD, RBE3 and MPC, MPCADD (as multipoint constraints, see `rigid.rs`),
//! EIGRL with the case control's `METHOD = n` (the band and number of modes asked for,
//! [`BulkImport::eigen_request`], which the `modes` stage follows when given no count or
//! limit of its own; see `eigrl.rs`),
//! PARAM GRDPNT (its reference point, for the weight summary mesh.import prints), and PARAM
//! WTMASS (applied to every
//! mass), COUPMASS, AUTOSPC, K6ROT and G (accepted with a warning saying what femu does
//! instead). Cards that change neither stiffness, mass nor constraints ([`SKIPPED_CARDS`],
//! PARAMs of [`SKIPPED_PARAMS`]) are skipped and counted in [`BulkImport::skipped`]. Every other
//! card may change the model: all of them are listed, with counts and first lines, in one
//! error, unless the user lists them in [`BulkOptions::ignore_cards`] or sets
//! [`BulkOptions::on_unsupported`] to [`Unsupported::Warn`] (then they are counted in
//! [`BulkImport::ignored`]). A deck without elements is an error.
//!
//! Files are read through [`crate::core::input`] (regular files only, bounded size, optional
//! confinement). Messages quote at most [`EXCERPT_CHARS`] characters of a line, and nothing of a
//! file in which no Nastran card has been seen.
//!
//! Values femu's elements cannot take are refused at the card, so that `femu validate` finds
//! them: MAT1 E > 0 (given or derived), G ≥ 0, −1 < NU ≤ 0.5 (< 0.5 for shells), RHO ≥ 0;
//! PSHELL T, 12I/T³, TS/T > 0; PBAR/PBEAM A, I1, I2 > 0, J, K1, K2 ≥ 0 (at every station);
//! PROD/CONROD A > 0, J ≥ 0; PTUBE OD, OD2 > 0, 0 ≤ T ≤ OD/2, OD2/2; NSM ≥ 0; spring stiffnesses ≥ 0; CONM2
//! mass ≥ 0. Every element is then checked as the assembly would check it, naming its card.
//!
//! Deviations from Nastran, each stated where it happens:
//! - GRID: positions are placed in the basic system from any CP. A grid whose CD axes are not
//!   the basic ones has a displacement system in the model ([`Model::displacement_systems`]):
//!   its DOFs — PS, SPC, SPC1, CELAS, MPC and rigid-element components, mode shapes and
//!   responses — are components along the CD axes at the grid, as in Nastran, and the assembly
//!   turns element matrices into them. SEID is ignored; CD −1 (fluid grid) is an error.
//! - CORD1x/CORD2x: references (RID, the CORD1 grids, a grid's CP) are followed in dependency
//!   order; an undefined reference or a cycle is an error at the card. On the polar axis of a
//!   cylindrical or spherical system the undefined angle is taken as 0.
//! - CQUAD4/CTRIA3 (and CQUADR/CTRIAR, `laminates.rs`): THETA is the material axis' angle from
//!   the G1→G2 edge projected on the element, MCID (an integer) a system whose x axis
//!   (rectangular) or r axis at the element centre, the mean of its corners (cylindrical,
//!   spherical; QRG CQUAD4) is projected on the element (MCID 0: basic x; an axis normal to the
//!   element is an error); they orient MAT2/MAT8 materials and do not change an
//!   isotropic shell. ZOFFS offsets the reference plane along the element normal, as Nastran's
//!   constitutive offset (`B + z0 A`, `D + 2 z0 B + z0² A`, mass moments alike; the rotary
//!   inertia is about the grid plane, θz included); non-structural mass stays on the grid
//!   plane. Corner thicknesses T1–T4 are ignored with a warning (the PSHELL T is used).
//!   CQUADR/CTRIAR are formed as femu's quad4/tria3 (which have a drilling penalty), not
//!   Nastran's drilling formulation: a warning once per deck.
//! - PCOMP/PCOMPG: classical lamination theory (`crate::fe::laminate`) of MAT1, MAT2 or MAT8
//!   plies, bottom to top from Z0 (blank: −T/2); blank MIDi/Ti repeat the previous ply's; LAM
//!   blank, SYM, MEM (only the membrane terms `A`), BEND (only `D` and the transverse shear) or
//!   SMEAR (stacking ignored: the derived shell's MID2 = MID1, `D = A T²/12` about the middle
//!   surface, no MID4; femu keeps the stack's transverse shear, as for a PSHELL without MID3);
//!   SMCORE (a sandwich: the last ply is the core, the earlier plies the face sheets, smeared
//!   and split half below, half above the core; `B = 0`; Z0 other than −T/2 is an error, as in
//!   Nastran); other LAM words are errors; NSM per area.
//!   Deviation: the transverse shear stiffness is `5/6 Σ Ḡ_k t_k` (first-order shear theory),
//!   not Nastran's equilibrium-based laminate shear (equal for one material; O((T/λ)²) on
//!   frequencies otherwise). SB, FT, TREF, SOUT are not used; GE ≠ 0 is not applied (warning).
//!   PCOMPG reads one ply per line (GPLYID MID T THETA SOUT); the DS/NRPT lines are errors.
//! - MAT8: E1, E2, NU12, G12 (> 0, NU12² < E1/E2), G1Z/G2Z, RHO; G1Z/G2Z blank (Nastran: rigid
//!   in transverse shear) take G12, with a warning once per deck. MAT2: G11–G33 (positive
//!   definite) and RHO; as a ply or MID3 its transverse shear moduli are G33 (MAT2 has none),
//!   with a warning. Expansion coefficients, allowables, TREF, GE and MCSID are not used.
//! - CQUAD8/CTRIA6 (`shells_quadratic.rs`): curved 8- and 6-node shells (MITC shear,
//!   `src/fe/shell_quadratic.rs`) with the same PSHELL parts as CQUAD4. A blank (or 0) midside
//!   grid means a straight edge, as the QRG says: femu slaves that edge's midside motion to the
//!   corners linearly (`u_m = (u_a + u_b)/2`). ZOFFS ≠ 0 is an error; THETA/MCID is ignored
//!   (isotropic material); a PCOMP/PCOMPG property, a MAT2/MAT8 material or MID4 on one is an
//!   error (the kernel is isotropic); T1–T4 and TFLAG are ignored with a warning (the PSHELL T
//!   is used).
//!   The lumped mass is HRZ-diagonal (all nodes positive; Nastran's own lumping of CQUAD8
//!   distributes by area too but its exact split is not documented), the coupled mass
//!   consistent; frequencies agree with Nastran's to formulation accuracy, not round-off.
//! - CBAR/CBEAM: the orientation is X1–X3 or G0 (from GA); blank PID, orientation and OFFT
//!   take the BAROR (CBAR) or BEAMOR (CBEAM) values, a blank PID without them the EID, a blank
//!   orientation without them is an error. OFFT as the QRG: `v` in GA's displacement system
//!   (G) or basic (B); WA, WB in GA's/GB's displacement system (G) or the element system (O),
//!   whose `x` is taken from GA to GB (not from the offset ends) and `y` in the plane of `x` and
//!   `v`. Offsets are rigid links; pin flags PA/PB (element-system DOFs at the offset end) are
//!   condensed statically with the mass made consistent with the condensed motion
//!   (`src/fe/beam.rs`); releases leaving a mechanism are errors. The model holds offsets in
//!   basic. CBEAM: a real BIT in OFFT is ignored (p-elements only); warping points SA/SB are
//!   ignored with a warning; its axis is the section's shear centre, with the neutral axis and
//!   the NSM centre of gravity offset from it as its PBEAM/PBEAML says (see PBEAM, PBEAML).
//! - PSHELL (QRG meaning): MID1 the membrane material (blank: no membrane), MID2 the bending
//!   material (blank: membrane only — no bending, transverse shear, drilling stiffness or rotary
//!   inertia, so the rotations of a membrane-only mesh are dropped as AUTOSPC does), MID3 the
//!   transverse shear material, 12I/T³ scales the bending stiffness (not the rotary inertia),
//!   TS/T is the shear correction factor (0.833333 read as 5/6). The mass is ρ·T + NSM with
//!   MID1's density (MID2's when MID1 is blank). Deviation: MID3 blank means no transverse
//!   shear flexibility (Kirchhoff) to Nastran; femu keeps its Mindlin shear with MID2's G and
//!   says so once per deck (an O((T/wavelength)²) effect: about 5e-4 at T/span = 0.01). MID4
//!   (membrane–bending coupling, `B = T² G4`) and MAT2/MAT8 parts are read through the general
//!   law of `crate::fe::laminate`. MID2 = −1 (plane strain), MID3 without MID2 and MID1 and MID2
//!   both blank are errors; Z1/Z2 (stress recovery) are ignored. T must be given (> 0).
//! - CROD/PROD, CTUBE/PTUBE, CONROD: axial `EA/L` and torsional `GJ/L` stiffness; mass
//!   (ρA + NSM)L, Nastran's lumped rod mass (half per end on the translations) or coupled mass
//!   (`m/6 [[2, 1], [1, 2]]` on all three translations), no torsional inertia (as Nastran). C
//!   (torsional stress coefficient) is kept for write-back only. PTUBE: A = π(OD − T)T,
//!   J = π(OD⁴ − ID⁴)/32, T blank or 0 a solid rod. OD2 ≠ OD (blank or 0: OD) is a tapered tube:
//!   OD linear from end A to end B at constant T, `A(x)` and `J(x)` from the same formulas,
//!   stiffness `1/∫ ds/EA` and `1/∫ ds/GJ` (exact for the taper), mass `∫ m̄ NᵢNⱼ` (consistent) or
//!   split by the first moment (lumped); Nastran's own treatment of OD2 is not specified in the
//!   QRG. CROD must
//!   name a PROD and CTUBE a PTUBE (PID blank: the EID). CONROD has no property id: its section
//!   is the element's own, so it is in no `pid<N>` set (name it in a SET1 to update it).
//! - PBAR: I1 (plane 1) is the second moment about the element z axis, I2 about y; K1/K2 blank
//!   or 0 mean no shear flexibility; I12 ≠ 0 is an error; stress points are ignored.
//! - PBARL: GROUP must be blank or MSCBML0; TYPE BAR (DIM1 → `width`, DIM2 → `height`; the QRG
//!   figure puts DIM1 along element z and DIM2 along element y, so I1 = DIM1·DIM2³/12), ROD
//!   (DIM1 radius), TUBE (DIM1 outer, DIM2 inner radius) and TUBE2 (DIM2 wall thickness) keep
//!   femu's own sections (Saint-Venant J of the rectangle, Cowper shear factors); I, I1, T, T1,
//!   T2, L, CHAN, CHAN1, CHAN2, BOX, BOX1, H, CROSS, Z, HAT become general sections with the
//!   values of [`crate::model::sections`] (exact A, I1, I2, I12; thin-walled J on wall
//!   centrelines, Bredt–Batho for boxes; shear factors from the web and flange areas). The QRG
//!   gives figures, not formulas: where Nastran's own J differs at O(t/b), femu's is the
//!   documented thin-walled value. HEXA, HAT1, DBOX and the other types are errors. A section
//!   with I12 ≠ 0 (L, Z, BOX1 with unequal walls) is turned to principal axes: the elements'
//!   orientation vectors turn by the same angle, and it has no shear flexibility (PBAR remark
//!   4: K1/K2 are ignored when I12 ≠ 0); a pin releasing one bending direction of such an
//!   element is an error. Like Nastran, PBARL puts the neutral axis on the shear centre.
//! - Tapered beams (`src/fe/beam_tapered.rs`): the stations of a PBEAM or PBEAML (SO, X/XB
//!   and the station's values; the last station must be end B, X/XB = 1, and X/XB must increase)
//!   are read. Blank end-B values are end A's; blank values of an intermediate station are
//!   interpolated linearly between end A and end B at its X/XB (a PBEAML's blank X/XB is 1.0).
//!   Stations that all repeat end A (to 1e-9 relative) are the uniform beam. PBEAM: `A, I1, I2,
//!   J` and NSM vary linearly between stations (I12 must be 0 at every station, J > 0 at every
//!   station or 0 at all); PBEAML: the dimensions and NSM vary linearly and the properties are
//!   computed from them at each point. The stiffness is the exact flexibility-method matrix of
//!   the varying Timoshenko beam (K1/K2 as below), the consistent mass integrates the uniform
//!   element's interpolation against the varying mass and inertia, and the lumped mass puts
//!   each end's share by the first moment of the mass distribution (total and centre of mass
//!   exact; half each for a uniform beam, as Nastran). The QRG does not say how Nastran
//!   integrates a taper, so femu's tapered matrices agree with Nastran's to the accuracy of
//!   its integration, not digit for digit. The property's `section`/`nsm` hold end A's values.
//!   Updating: E and density act as on any beam; a tapered BAR's width/height (DIM1/DIM2)
//!   scale that dimension at every station in proportion (the parameter's value is end A's);
//!   other section parameters do not apply. The write-back of an update refuses (naming the
//!   card) to change a tapered property's section.
//! - PBEAML: the element axis is the section's shear centre (QRG PBEAML remarks 7 and 12,
//!   default MDLPRM TWBRBML = 0): a section that is not doubly or point symmetric (T, T1, T2,
//!   L, CHAN, CHAN1, CHAN2, HAT, I with unequal flanges, BOX1 with unequal opposite walls) has
//!   its centroid offset from it by the thin-walled centreline shear centre
//!   ([`crate::model::sections::neutral_axis_offset`], in the turned axes of an L or BOX1), as
//!   the equivalent PBEAM's N1/N2; the mechanics are those of PBEAM's offsets below. A tapered
//!   section must keep that offset at every station (to 1e-9 of its largest dimension; the
//!   element holds it constant), else an error names the station; a tapered section with a
//!   product of inertia (whose principal axes would turn along the beam) is an error.
//! - PBEAM: K1/K2 default 1.0 (0 = no shear flexibility). I12 ≠ 0 is an error; CW (warping)
//!   is ignored with a warning (Nastran ignores it too without warping scalar points). N1/N2
//!   (neutral axis), M1/M2 (NSM centre of gravity) and NSI (NSM mass moment of inertia per
//!   length, ≥ 0) are applied with Nastran's meaning (`src/fe/beam_offset.rs`): the grid line
//!   is the shear centre, the axial strain is the centroid's, the structural mass sits at the
//!   centroid and the NSM at M, rigidly linked. Blank end-B values are end A's (QRG); end-B
//!   values that differ from end A's are an error naming the field (the element holds the
//!   offsets constant).
//! - MAT1: a blank E, G or NU is derived from the other two (E = 2(1+NU)G). With only E given,
//!   NU = 0 (Nastran sets G = 0; femu's isotropic material has G = E/2) with a warning. When all
//!   three are given and inconsistent, E and NU are kept and a warning names the G used.
//! - SPOINT/EPOINT (with THRU): scalar points, one DOF `id:s` each without position; ids
//!   shared with a GRID are an error. An EPOINT (extra point) only matters to transfer
//!   functions and direct-response equations, which femu does not read, so it is a scalar
//!   point that nothing connects unless an element names it, and such a DOF is dropped like an
//!   unconnected rotation. SPC/SPC1 constrain a scalar point with component 0 or blank.
//! - CELAS1–4, CMASS1–4, CDAMP1–4 (scalar elements, `scalars.rs`): CxxxS1/2 connect grid
//!   components (1–6) or scalar points (0 or blank), CxxxS3/4 scalar points only; a mass or
//!   damper between two DOFs is `v [[1, −1], [−1, 1]]` (the QRG's "between two points"). GE and
//!   S of CELAS are ignored (GE ≠ 0 warns). CDAMP5 (heat transfer) is an error. The masses are
//!   multiplied by WTMASS; dampers give the viscous `C` of direct FRFs (not the modes).
//! - CVISC/PVISC: axial damping CE along G1→G2 and torsional CR about it.
//! - CONM1: the 6×6 symmetric mass M11…M66 at the grid, given in CID's directions at the grid
//!   (CID blank or 0: basic) and rotated to basic, `M_b = Tᵀ M T`; multiplied by WTMASS.
//! - CHEXA/CPENTA/CTETRA/CPYRAM, PSOLID, MAT9 (`solids.rs`, kernels in `src/fe/solid/`):
//!   HEXA8 (2×2×2 Gauss with Wilson–Taylor incompatible modes, close to MSC's default
//!   bubble-enhanced CHEXA but not digit for digit), HEXA20, PENTA6, PENTA15, TETRA4, TETRA10,
//!   PYRAM5 and PYRAM13 (Bedrosian's rational 13-node pyramid) fully integrated; PSOLID IN/ISOP
//!   other than blank are read as that formulation with a warning. Midside grids: any subset,
//!   blank or 0 meaning none (QRG); a partial set is Bathe's variable-node element (an edge
//!   without its grid straight, the displacement linear along it; no incompatible modes in a
//!   partial CHEXA). Repeated grids, FCTN other than SMECH, a MAT9 in the element system (CORDM
//!   −1) or in a cylindrical/spherical CORDM are errors; CORDM is ignored for a MAT1
//!   (isotropic). A zero or negative Jacobian at an integration point is an error naming the
//!   element card and the node order the QRG asks for. Solids carry no rotational stiffness or
//!   mass: their grids' rotations are dropped unless other elements reach them (AUTOSPC).
//!   Consistent mass, or with `mass: lumped` the HRZ diagonal (Nastran's lumped solid mass is
//!   the same `ρV` spread by other weights for quadratic shapes).
//! - CBUSH/PBUSH: the K and B (viscous damping) lines are used (GE, RCV, M… ignored with a
//!   warning). Element system as the QRG: CID ≥ 0 its axes (a cylindrical or spherical CID
//!   evaluated at GA); CID blank: x from GA to GB, y in the plane of x and the orientation
//!   vector (X1–X3 in GA's displacement system, or G0); CID blank with GB blank or within 1e-4
//!   of GA is an error (Nastran requires CID). Deviation: CID and orientation both blank between
//!   distinct grids take the basic axes, with a warning. The spring location (S, OCID, S1–S3) is
//!   ignored with a warning (no lever arm is modelled).
//! - CONM2: CID 0 (offset X1–X3 in basic), −1 (X1–X3 are the basic coordinates of the centre
//!   of gravity) or a coordinate system (offset and inertia along its directions at the grid;
//!   the inertia is rotated with the QRG's sign convention for I21, I31, I32).
//! - SPC: a non-zero D is taken as 0 with a warning (it does not change the modes). The case
//!   control's `SPC = n` (the lines after CEND and before BEGIN BULK of the top file) selects
//!   an SPC/SPC1 set or an SPCADD of them; subcases that select different sets give a warning
//!   and the first is used. Without case control, every set is merged into one constraint list
//!   (several SIDs give a warning). GRID PS always applies. THRU ranges cover the grids that
//!   exist. Constraints come back sorted and without repeats.
//! - RBE2, RBAR, RBE1, RROD, RBE3, MPC, MPCADD: multipoint constraints `u_d = Σ cᵢ uᵢ` over the
//!   grids' own DOFs (small rotations; components in each grid's CD); the assembly eliminates them exactly. The
//!   case control's `MPC = n` selects the MPC set (none selected in a deck with case control: no
//!   MPC applies, with a warning; no case control: every set, with a warning when several).
//!   A DOF dependent twice, dependent and in the SPC set, or a cycle of dependencies is an
//!   error naming the cards. RBE3 UM fields, RBAR1, RSPLINE and scalar points in MPC are
//!   not read (errors). With a CD not parallel to basic and only some components of a grid
//!   dependent, the dependent basic components are chosen by pivoting (the constraint is the
//!   same; the DOF labelled dependent may differ from Nastran's). ALPHA/TREF are ignored.
//! - SET1: element ids (with THRU over existing elements, optional SKIN) → set `set<SID>`, ids
//!   sorted without repeats.
//! - Integers are accepted where a real is expected (Nastran wants a decimal point), except where
//!   the type decides the meaning (CBAR/CBEAM/CBUSH X1 against G0).
//! - Replication (`=`, `==`, `*x`, `=n`) of single-line entries is read
//!   ([`replicate`](self::replicate)); an entry with continuations cannot be replicated.
//! - Unsorted decks (continuations away from their parent) are not supported; a free-field
//!   line may hold at most ten fields.
//! - femu extensions written by the exporter and read back: `$femu-set <sid> <name>` names the
//!   SET1 `<sid>` (or an empty set), `$femu-parameter <json>` holds an updating parameter.
//!
//! After reading, [`Model::add_property_sets`] adds `pid<N>` sets and [`Model::validate`] checks
//! every reference; a failure names the card that holds the dangling reference.

use crate::core::input::{EXCERPT_CHARS, InputError, InputPolicy, excerpt, read_input_with};
use crate::core::{Component, DofId};
use crate::model::structure::{
    BeamCentres, BeamEnds, BeamProperty, BeamSection, BeamStation, BeamTaper, Element, Material,
    Model, ModelError, Parameter, ShellProperty,
};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::rc::Rc;

mod builder;
mod card;
mod constraints;
mod coords;
mod deck;
mod eigrl;
mod elements;
mod finish;
mod laminates;
mod lumped;
mod numbers;
mod properties;
mod replicate;
mod rigid;
mod rods;
mod scalars;
mod sections;
mod shells_quadratic;
mod solids;
mod source;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_beams;
#[cfg(test)]
mod tests_cd;
#[cfg(test)]
mod tests_laminates;
#[cfg(test)]
mod tests_quadratic;
#[cfg(test)]
mod tests_replicate;
#[cfg(test)]
mod tests_rigid;
#[cfg(test)]
mod tests_rods;
#[cfg(test)]
mod tests_scalars;
#[cfg(test)]
mod tests_shear_centre;
#[cfg(test)]
mod tests_solids;
#[cfg(test)]
mod tests_tapered;

use builder::*;
use card::*;
use coords::*;
pub use deck::{Deck, DeckCard, DeckField, DeckFile, DeckInclude, read_deck};
pub(crate) use numbers::parse_real;
use numbers::*;
use source::*;

/// Deepest INCLUDE nesting accepted.
const MAX_INCLUDE_DEPTH: usize = 64;

/// Cards femu reads.
pub const READ_CARDS: [&str; 74] = [
    "GRID", "GRDSET", "CORD1R", "CORD1C", "CORD1S", "CORD2R", "CORD2C", "CORD2S", "CQUAD4",
    "CTRIA3", "CBAR", "CBEAM", "PSHELL", "PBAR", "PBARL", "PBEAM", "MAT1", "CELAS1", "CELAS2",
    "PELAS", "CBUSH", "PBUSH", "CONM2", "SPC", "SPC1", "SPCADD", "SET1", "CROD", "CONROD", "CTUBE",
    "PROD", "PTUBE", "PBEAML", "BAROR", "BEAMOR", "RBE2", "RBAR", "RROD", "RBE3", "MPC", "MPCADD",
    "CHEXA", "CPENTA", "CTETRA", "CPYRAM", "PSOLID", "MAT9", "CQUADR", "CTRIAR", "PCOMP", "PCOMPG",
    "MAT2", "MAT8", "SPOINT", "EPOINT", "CELAS3", "CELAS4", "CMASS1", "CMASS2", "CMASS3", "CMASS4",
    "PMASS", "CONM1", "CDAMP1", "CDAMP2", "CDAMP3", "CDAMP4", "PDAMP", "CVISC", "PVISC", "CQUAD8",
    "CTRIA6", "EIGRL", "RBE1",
];

/// Cards skipped (counted) because they change neither stiffness, mass nor constraints: static
/// and dynamic loads and their tables, temperatures (femu has no temperature-dependent
/// material, and MATT1 is refused), eigenvalue and frequency-response control, plot elements.
pub const SKIPPED_CARDS: [&str; 40] = [
    "FORCE", "FORCE1", "FORCE2", "MOMENT", "MOMENT1", "MOMENT2", "LOAD", "PLOAD", "PLOAD1",
    "PLOAD2", "PLOAD4", "GRAV", "RFORCE", "ACCEL", "ACCEL1", "LSEQ", "DAREA", "DLOAD", "RLOAD1",
    "RLOAD2", "TLOAD1", "TLOAD2", "DPHASE", "DELAY", "TABLED1", "TABLED2", "TABLED3", "TABLED4",
    "TEMP", "TEMPD", "EIGR", "EIGC", "EIGB", "FREQ", "FREQ1", "FREQ2", "FREQ3", "FREQ4", "TSTEP",
    "PLOTEL",
];

/// PARAM names skipped (counted): output and diagnostics only. WTMASS is applied; COUPMASS,
/// AUTOSPC, K6ROT and G are accepted with a warning that says what femu does instead.
pub const SKIPPED_PARAMS: [&str; 18] = [
    "POST", "POSTEXT", "PATVER", "PRGPST", "MAXRATIO", "BAILOUT", "NOCOMPS", "OGEOM", "OUGCORD",
    "PRTMAXIM", "NOELOF", "NOELOP", "NOGPF", "ELSUMOUT", "SRCOMPS", "OMACHPR", "DBALL", "RESVEC",
];

/// PARAM names with a meaning femu applies or replaces (see [`SKIPPED_PARAMS`]).
pub const READ_PARAMS: [&str; 6] = ["WTMASS", "GRDPNT", "COUPMASS", "AUTOSPC", "K6ROT", "G"];

/// Nastran cards femu does not read that change the stiffness, mass, damping or constraints;
/// an error unless listed in [`BulkOptions::ignore_cards`] (the list only decides how messages
/// name them: any other unread card is an error too).
const REFUSED_CARDS: [&str; 37] = [
    "RBAR1", "RTRPLT", "RSPLINE", "SPCD", "SUPORT", "SUPORT1", "ASET", "ASET1", "OMIT", "OMIT1",
    "QSET", "QSET1", "BSET", "BSET1", "CSET", "CSET1", "CQUAD", "CSHEAR", "PSHEAR", "MAT10",
    "MATT1", "MATS1", "CDAMP5", "CBUSH1D", "PBUSH1D", "CGAP", "PGAP", "CWELD", "PWELD", "CFAST",
    "PFAST", "NSM", "NSM1", "NSML", "NSML1", "DMIG", "GENEL",
];

/// Whether `name` is a card name Nastran could have written: a letter, then letters or digits,
/// at most 8 characters.
fn is_card_name(name: &str) -> bool {
    let b = name.as_bytes();
    !b.is_empty()
        && b.len() <= 8
        && b[0].is_ascii_alphabetic()
        && b.iter().all(|c| c.is_ascii_alphanumeric())
}

/// Whether `name` is a card femu knows to be Nastran's (read, skipped or refused).
fn is_known_card(name: &str) -> bool {
    name == "PARAM"
        || READ_CARDS.contains(&name)
        || SKIPPED_CARDS.contains(&name)
        || REFUSED_CARDS.contains(&name)
}

/// A model read from a bulk data deck, with what was skipped.
#[derive(Clone, Debug, PartialEq)]
pub struct BulkImport {
    /// The model (with `pid<N>` sets added, validated).
    pub model: Model,
    /// Cards that are not read, by name (`PARAM,NAME` for PARAM), with how often each occurs:
    /// the union of `skipped` and `ignored`.
    pub unknown: BTreeMap<String, usize>,
    /// Cards skipped because they do not change the stiffness, mass or constraints (loads,
    /// analysis and output control), with their counts.
    pub skipped: BTreeMap<String, usize>,
    /// Cards dropped because the user listed them in [`BulkOptions::ignore_cards`], with counts.
    pub ignored: BTreeMap<String, usize>,
    /// Deviations from Nastran's meaning that did not stop the import, each naming file and line.
    pub warnings: Vec<String>,
    /// blake3 of the bytes of the deck and every file it INCLUDEs, in reading order: changes
    /// whenever any of them does.
    pub source_digest: String,
    /// PARAM,GRDPNT's reference point (basic coordinates of its grid, or the origin for 0):
    /// the deck asks for the rigid-body mass summary about it.
    pub grdpnt: Option<[f64; 3]>,
    /// The modes the case control's `METHOD = n` asks for through its EIGRL card (or the
    /// deck's only EIGRL when it has no case control).
    pub eigen_request: Option<crate::eigen::EigenRequest>,
}

/// Why a bulk data deck could not be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NastranError {
    /// A file could not be read.
    #[error("cannot read Nastran bulk data file `{path}`: {message}")]
    Io {
        /// The path.
        path: Box<str>,
        /// The operating system's message.
        message: Box<str>,
    },
    /// An INCLUDE statement that cannot be followed.
    #[error("{file} line {line}: INCLUDE {problem}; {valid}")]
    Include {
        /// File holding the INCLUDE.
        file: Box<str>,
        /// Its line.
        line: usize,
        /// What is wrong.
        problem: Box<str>,
        /// What would be valid.
        valid: Box<str>,
    },
    /// A line that is neither a card, a continuation nor a comment.
    #[error("{file} line {line}: {problem}; {valid}")]
    Syntax {
        /// File.
        file: Box<str>,
        /// Line.
        line: usize,
        /// What is wrong.
        problem: Box<str>,
        /// What would be valid.
        valid: Box<str>,
    },
    /// A field of a card is malformed, missing, unsupported or refers to nothing.
    #[error(
        "{file} line {line}: {card} field {field} ({label}){}: {problem}; {valid}",
        row_note(.row, .field_line, .line)
    )]
    Field {
        /// File.
        file: Box<str>,
        /// Line of the card's first line.
        line: usize,
        /// Card name.
        card: Box<str>,
        /// Continuation holding the field (0: the card's first line).
        row: usize,
        /// Field number 1–10 on that line, as in the QRG.
        field: usize,
        /// File line holding the field.
        field_line: usize,
        /// The QRG's name for the field.
        label: Box<str>,
        /// What is wrong.
        problem: Box<str>,
        /// What would be valid.
        valid: Box<str>,
    },
    /// An id defined twice.
    #[error(
        "{file} line {line}: {card} field {field} ({label}): {what} {id} is already defined at {first}; ids must be unique"
    )]
    Duplicate {
        /// File.
        file: Box<str>,
        /// Line of the second definition.
        line: usize,
        /// Card name.
        card: Box<str>,
        /// Field number of the id, as in the QRG.
        field: usize,
        /// The QRG's name for the field.
        label: &'static str,
        /// Kind of id (grid, element, property, …).
        what: &'static str,
        /// The id.
        id: u64,
        /// Where the first definition is (`file line N`).
        first: Box<str>,
    },
    /// An element femu's assembly cannot build from the values of its cards.
    #[error(
        "{file} line {line}: {card} {id}{uses}: {message}; correct the element's grids or the property and material it uses"
    )]
    Element {
        /// File of the element card.
        file: Box<str>,
        /// Its line.
        line: usize,
        /// The element card's name.
        card: Box<str>,
        /// Element id.
        id: u64,
        /// The property and material it uses, with where they are defined.
        uses: Box<str>,
        /// What the element check found.
        message: Box<str>,
    },
    /// The deck defines no element: nothing to assemble.
    #[error("{file}: {problem}; {valid}")]
    Empty {
        /// The top file.
        file: Box<str>,
        /// What was found.
        problem: Box<str>,
        /// What would be valid.
        valid: Box<str>,
    },
    /// Cards femu does not read that may change the stiffness, mass or constraints.
    #[error(
        "{file}: {count} card(s) femu does not read may change the stiffness, mass or constraints, so the deck cannot be imported as it is: {cards}; {valid}"
    )]
    Unsupported {
        /// The top file.
        file: Box<str>,
        /// How many such cards in all.
        count: usize,
        /// Each card name with its count and first place.
        cards: Box<str>,
        /// What would be valid.
        valid: Box<str>,
    },
    /// The deck is complete but inconsistent (a reference to something not defined).
    #[error("{file} line {line}: {source}; {valid}")]
    Model {
        /// File of the card holding the reference.
        file: Box<str>,
        /// Its line.
        line: usize,
        /// The model check that failed.
        source: ModelError,
        /// What would be valid.
        valid: Box<str>,
    },
}

fn row_note(row: &usize, field_line: &usize, line: &usize) -> String {
    if *row > 0 {
        format!(" of continuation {row} (line {field_line})")
    } else if field_line != line {
        format!(" (line {field_line})")
    } else {
        String::new()
    }
}

/// Choices of the user that change what an import accepts.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BulkOptions {
    /// Card names (upper case; `PARAM,NAME` for one PARAM) the user accepts to drop although
    /// they may change the stiffness, mass or constraints.
    pub ignore_cards: BTreeSet<String>,
    /// What to do with cards femu does not read that may change the model.
    pub on_unsupported: Unsupported,
}

/// What an import does with cards it does not read that may change the stiffness, mass or
/// constraints.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Unsupported {
    /// Refuse the deck, listing every such card with its count and first line.
    #[default]
    Error,
    /// Drop them, count them in [`BulkImport::ignored`], and say so in one warning.
    Warn,
}

/// Reads a bulk data file (and the files it includes) under the process-wide input policy,
/// refusing every card it does not read unless it is known to be harmless.
pub fn read_bulk(path: impl AsRef<Path>) -> Result<BulkImport, NastranError> {
    read_bulk_with(path, &BulkOptions::default())
}

/// [`read_bulk`] with options.
pub fn read_bulk_with(
    path: impl AsRef<Path>,
    options: &BulkOptions,
) -> Result<BulkImport, NastranError> {
    let path = path.as_ref();
    let io = |e: InputError| NastranError::Io {
        path: path.display().to_string().into(),
        message: e.to_string().into(),
    };
    let policy = crate::core::input::policy().map_err(io)?;
    let bytes = read_input_with(path, &policy, policy.max_bytes).map_err(io)?;
    parse_with_policy(
        &String::from_utf8_lossy(&bytes),
        &path.display().to_string(),
        options,
        policy,
        bytes.len() as u64,
    )
}

/// Parses bulk data text; `file_name` names it in messages and anchors relative INCLUDEs
/// (read under the process-wide input policy).
pub fn parse_bulk(text: &str, file_name: &str) -> Result<BulkImport, NastranError> {
    parse_bulk_with(text, file_name, &BulkOptions::default())
}

/// [`parse_bulk`] with options.
pub fn parse_bulk_with(
    text: &str,
    file_name: &str,
    options: &BulkOptions,
) -> Result<BulkImport, NastranError> {
    let policy = crate::core::input::policy().map_err(|e| NastranError::Io {
        path: file_name.into(),
        message: e.to_string().into(),
    })?;
    parse_with_policy(text, file_name, options, policy, text.len() as u64)
}

fn parse_with_policy(
    text: &str,
    file_name: &str,
    options: &BulkOptions,
    policy: InputPolicy,
    used: u64,
) -> Result<BulkImport, NastranError> {
    let path = Path::new(file_name);
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut loader = Loader {
        policy,
        used,
        job_dir: dir.clone(),
        ..Loader::default()
    };
    loader.digest_source(text.as_bytes());
    loader
        .stack
        .push(std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()));
    loader.load(text, Rc::from(file_name), &dir, true)?;
    let cards = assemble(&loader.lines, &mut loader.warnings)?;
    let mut builder = Builder {
        top_file: Rc::from(file_name),
        warnings: std::mem::take(&mut loader.warnings),
        ignore: options.ignore_cards.clone(),
        on_unsupported: options.on_unsupported,
        ..Builder::default()
    };
    for card in &cards {
        builder.card(card)?;
    }
    builder.check_unsupported()?;
    builder.case_control = std::mem::take(&mut loader.case_control);
    builder.rigid.case_control = std::mem::take(&mut loader.case_control_mpc);
    builder.rigid.has_case_control = loader.has_case_control;
    builder.case_control_method = std::mem::take(&mut loader.case_control_method);
    let mut import = builder.finish(loader.set_names, loader.parameters)?;
    import.source_digest = loader.source.finalize().to_hex().to_string();
    Ok(import)
}
