//! What the keeper refuses beyond single numbers: a robot whose chain a transaction leaves
//! ambiguous, and mass properties no body has. Called from [`Store::apply`](super::Store::apply)
//! on every path that writes the model (model load, `lang load`, editor, transactions), so a
//! file reader that forgets a check still cannot put such a robot in the Instance Space.
//!
//! * [`mass_props`] — mass finite and ≥ 0; inertia about the centre of mass symmetric (stored as
//!   six numbers) and positive semi-definite (eigenvalues ≥ −1e-9·largest). A massless link may
//!   carry inertia, and the triangle inequality of the principal moments is not enforced: the
//!   standard Puma 560 data (Corke) has both.
//! * [`Stage::check_chains`] — for every robot the transaction touched: the joint indices of its
//!   links are unique and exactly 0..n, all joints are DH rows or all are general joints, and
//!   every DH row uses the robot's one convention (standard or modified).
//!
//! Entry points: [`mass_props`], [`principal_moments`], [`Stage::check_chains`].

use super::{DhConvention, Id, Kind, Kinematics, MassProps, Op, Stage, TxError};
use std::collections::BTreeSet;

/// Relative tolerance of the inertia checks (a box computed in f64 sits on the triangle
/// inequality's boundary only for a degenerate, flat body).
pub const INERTIA_TOL: f64 = 1e-9;

/// The eigenvalues of the symmetric inertia `[xx, yy, zz, xy, xz, yz]` (kg·m²), ascending.
pub fn principal_moments(i: &[f64; 6]) -> [f64; 3] {
    let m = nalgebra::Matrix3::new(i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2]);
    let e = m.symmetric_eigenvalues();
    let mut v = [e[0], e[1], e[2]];
    v.sort_by(f64::total_cmp);
    v
}

/// Why mass properties are not those of a body: `(field, reason)`.
pub fn mass_props(m: &MassProps) -> Result<(), (&'static str, String)> {
    if !m.mass.is_finite() || m.mass < 0.0 {
        return Err(("mass", format!("{} kg: a mass is finite and ≥ 0", m.mass)));
    }
    if m.inertia.iter().all(|x| *x == 0.0) {
        return Ok(());
    }
    if m.inertia.iter().any(|x| !x.is_finite()) {
        return Err(("inertia", "has a non-finite entry".into()));
    }
    // A massless link with inertia is allowed: Corke's Puma 560 gives link 1 no mass but
    // Izz = 0.35 kg·m² (the rotating column's inertia about the fixed axis), and the standard
    // library has it so.
    let [a, b, c] = principal_moments(&m.inertia);
    let scale = c.abs().max(a.abs());
    let tol = INERTIA_TOL * scale;
    if a < -tol {
        return Err((
            "inertia",
            format!(
                "is not positive semi-definite: principal moments {a:e}, {b:e}, {c:e} kg·m² \
                 (one is negative)"
            ),
        ));
    }
    // The triangle inequality of the principal moments (c ≤ a + b) is not enforced: the
    // standard library's Puma 560 (Corke's data set) breaks it on link 3 (0.086 > 0.066 +
    // 0.0125 kg·m²) and on link 1 (massless, Izz = 0.35 alone), and refusing the reference
    // robot would break every session that uses it.
    Ok(())
}

/// A link's place in its robot's chain, as its kinematics say.
struct Place {
    link: Id,
    index: u32,
    dh: Option<DhConvention>,
}

impl Stage<'_> {
    /// The robots whose chains this transaction may have changed: each robot, and the robot
    /// (before and after) of each link, whose structure or kinematics it touched. Pose-only
    /// writes (joint values, the most frequent transactions) cannot change a chain and cost
    /// nothing here.
    fn touched_robots(&self) -> BTreeSet<Id> {
        use crate::store::aspect::{KINEMATICS, STRUCTURE};
        let mut robots = BTreeSet::new();
        for (&id, _) in self
            .touched
            .iter()
            .filter(|(_, mask)| *mask & (STRUCTURE | KINEMATICS) != 0)
        {
            for o in [self.lookup(id), self.model.objects.get(&id)]
                .into_iter()
                .flatten()
            {
                match o.kind {
                    Kind::Robot => {
                        robots.insert(id);
                    }
                    Kind::Link if o.parent != 0 => {
                        robots.insert(o.parent);
                    }
                    _ => {}
                }
            }
        }
        robots.retain(|&r| self.lookup(r).is_some_and(|o| o.kind == Kind::Robot));
        robots
    }

    /// The staged links of `robot` (committed children still under it, and objects this
    /// transaction put under it).
    fn links_of(&self, robot: Id) -> Vec<Id> {
        let mut ids: BTreeSet<Id> = self.model.children_of(robot).collect();
        ids.extend(
            self.overlay
                .iter()
                .filter(|(_, o)| o.as_ref().is_some_and(|o| o.parent == robot))
                .map(|(&id, _)| id),
        );
        ids.into_iter()
            .filter(|&id| {
                self.lookup(id)
                    .is_some_and(|o| o.parent == robot && o.kind == Kind::Link)
            })
            .collect()
    }

    /// The last op of `ops` that set `link`'s kinematics (or created it): the one to blame.
    fn blame(&self, ops: &[Op], link: Id) -> usize {
        ops.iter()
            .enumerate()
            .rev()
            .find(|(i, op)| match op {
                Op::SetKinematics { id, .. } => self.resolve(*i, *id).ok() == Some(link),
                _ => false,
            })
            .map_or(ops.len().saturating_sub(1), |(i, _)| i)
    }

    /// Every robot the transaction touched has one unambiguous chain (module docs).
    pub(super) fn check_chains(&self, ops: &[Op]) -> Result<(), TxError> {
        for robot in self.touched_robots() {
            let robot_convention = match self.lookup(robot).and_then(|o| o.kinematics) {
                Some(
                    Kinematics::Robot { convention, .. }
                    | Kinematics::FloatingRobot { convention, .. },
                ) => Some(convention),
                _ => None,
            };
            let places: Vec<Place> = self
                .links_of(robot)
                .into_iter()
                .filter_map(|link| match self.lookup(link)?.kinematics? {
                    Kinematics::Joint {
                        index, convention, ..
                    } => Some(Place {
                        link,
                        index,
                        dh: Some(convention),
                    }),
                    Kinematics::Axis { index, .. } | Kinematics::Mimic { index, .. } => {
                        Some(Place {
                            link,
                            index,
                            dh: None,
                        })
                    }
                    Kinematics::Robot { .. } | Kinematics::FloatingRobot { .. } => None,
                })
                .collect();
            let invalid = |link: Id, field: &str, reason: String| TxError::InvalidValue {
                op: self.blame(ops, link),
                id: link,
                field: field.into(),
                reason,
            };
            let n = places.len();
            let mut seen: Vec<Option<Id>> = vec![None; n];
            for p in &places {
                let Some(slot) = seen.get_mut(p.index as usize) else {
                    return Err(invalid(
                        p.link,
                        "kinematics.index",
                        format!(
                            "joint index {} is out of range: robot {robot} has {n} joints (0..{n})",
                            p.index
                        ),
                    ));
                };
                if let Some(other) = slot {
                    return Err(invalid(
                        p.link,
                        "kinematics.index",
                        format!(
                            "joint index {} is also link {other}'s: robot {robot}'s chain order \
                             would be ambiguous",
                            p.index
                        ),
                    ));
                }
                *slot = Some(p.link);
            }
            // a mimic joint follows another joint of the robot, not itself (cycles through
            // several followers are refused where the coupling is built:
            // robosim_scene::robot_coupling)
            for p in &places {
                if let Some(Kinematics::Mimic {
                    leader: Some(l), ..
                }) = self.lookup(p.link).and_then(|o| o.kinematics)
                    && (l as usize >= n || l == p.index)
                {
                    return Err(invalid(
                        p.link,
                        "kinematics.leader",
                        format!(
                            "joint {} follows joint {l}, which is {}: robot {robot} has {n} joints",
                            p.index,
                            if l == p.index {
                                "itself"
                            } else {
                                "out of range"
                            }
                        ),
                    ));
                }
            }
            let first_dh = places.iter().find_map(|p| p.dh.map(|c| (p.link, c)));
            let first_axis = places.iter().find(|p| p.dh.is_none()).map(|p| p.link);
            if let (Some((dh_link, _)), Some(axis_link)) = (first_dh, first_axis) {
                return Err(invalid(
                    dh_link.max(axis_link),
                    "kinematics",
                    format!(
                        "robot {robot} mixes a DH row (link {dh_link}) with a general joint \
                         (link {axis_link}): its joints are all one or all the other"
                    ),
                ));
            }
            if let Some((first_link, first)) = first_dh {
                let want = robot_convention.unwrap_or(first);
                for p in &places {
                    let Some(c) = p.dh else { continue };
                    if c != want {
                        let whose = if robot_convention.is_some() {
                            format!("robot {robot}'s")
                        } else {
                            format!("link {first_link}'s")
                        };
                        return Err(invalid(
                            p.link,
                            "kinematics.convention",
                            format!(
                                "this DH row is {} but {whose} is {}: one convention per robot",
                                name(c),
                                name(want)
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

fn name(c: DhConvention) -> &'static str {
    match c {
        DhConvention::Standard => "standard",
        DhConvention::Modified => "modified",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{JointKind, Store, Transaction};

    fn joint(index: u32, convention: DhConvention) -> Kinematics {
        Kinematics::Joint {
            index,
            joint: JointKind::Revolute,
            convention,
            a: 0.1,
            d: 0.0,
            alpha: 0.0,
            theta: 0.0,
            offset: 0.0,
            qlim: [-1.0, 1.0],
        }
    }

    /// A robot of links with these (index, convention) pairs, applied to a fresh store.
    fn robot(links: &[(u32, DhConvention)]) -> Result<Store, TxError> {
        let mut tx = Transaction::new();
        let r = tx.create(Kind::Robot, "r", None);
        for (j, &(index, c)) in links.iter().enumerate() {
            let l = tx.create(Kind::Link, &format!("l{j}"), Some(r));
            tx.set_kinematics(l, Some(joint(index, c)));
        }
        let mut m = Store::default();
        m.apply(&tx)?;
        Ok(m)
    }

    const S: DhConvention = DhConvention::Standard;
    const M: DhConvention = DhConvention::Modified;

    #[test]
    fn duplicate_joint_index_is_refused_not_silently_reordered() {
        assert!(robot(&[(0, S), (1, S), (2, S)]).is_ok());
        // written out of order is fine: the index says the order
        assert!(robot(&[(2, S), (0, S), (1, S)]).is_ok());
        let e = robot(&[(0, S), (1, S), (1, S)]).expect_err("duplicate");
        assert!(
            matches!(&e, TxError::InvalidValue { field, reason, .. }
                if field == "kinematics.index" && reason.contains("joint index 1 is also link")),
            "{e}"
        );
    }

    #[test]
    fn out_of_range_joint_index_is_refused_not_silently_reordered() {
        let e = robot(&[(0, S), (1, S), (5, S)]).expect_err("out of range");
        assert!(
            matches!(&e, TxError::InvalidValue { op, reason, .. }
                if reason.contains("joint index 5 is out of range") && reason.contains("(0..3)")
                    && *op == 6),
            "{e}"
        );
    }

    #[test]
    fn one_modified_link_among_standard_links_is_refused() {
        assert!(robot(&[(0, M), (1, M)]).is_ok());
        let e = robot(&[(0, S), (1, M), (2, S)]).expect_err("mixed conventions");
        assert!(
            matches!(&e, TxError::InvalidValue { field, reason, .. }
                if field == "kinematics.convention" && reason.contains("one convention per robot")),
            "{e}"
        );
    }

    #[test]
    fn a_later_transaction_that_breaks_the_chain_is_refused() {
        let mut m = robot(&[(0, S), (1, S)]).expect("valid");
        let link = m
            .objects()
            .find(|o| o.name == "l1")
            .map(|o| o.id)
            .expect("l1");
        let mut tx = Transaction::new();
        tx.set_kinematics(crate::ObjRef::Id(link), Some(joint(0, S)));
        assert!(m.apply(&tx).is_err());
    }

    #[test]
    fn non_positive_definite_inertia_is_refused_by_the_keeper() {
        let mut tx = Transaction::new();
        let r = tx.create(Kind::Robot, "r", None);
        let l = tx.create(Kind::Link, "l", Some(r));
        tx.set_dynamics(l, Some(props(1.0, [1.0, 1.0, -1.0, 0.0, 0.0, 0.0])));
        let e = Store::default().apply(&tx).expect_err("indefinite");
        assert!(
            matches!(&e, TxError::InvalidValue { field, .. } if field == "inertia"),
            "{e}"
        );
    }

    fn props(mass: f64, inertia: [f64; 6]) -> MassProps {
        MassProps {
            mass,
            com: [0.0; 3],
            inertia,
        }
    }

    #[test]
    fn mass_props_refuse_what_no_body_has() {
        // a 1 kg cube of 1 m: I = 1/6 on each axis
        let s = 1.0 / 6.0;
        assert!(mass_props(&props(1.0, [s, s, s, 0.0, 0.0, 0.0])).is_ok());
        assert!(mass_props(&props(0.0, [0.0; 6])).is_ok());
        assert_eq!(mass_props(&props(-2.0, [0.0; 6])).unwrap_err().0, "mass");
        let e = mass_props(&props(1.0, [1.0, 1.0, -1.0, 0.0, 0.0, 0.0])).unwrap_err();
        assert!(e.1.contains("positive semi-definite"), "{}", e.1);
        // Corke's Puma 560 link 3 breaks the triangle inequality; it is accepted
        assert!(mass_props(&props(4.8, [0.066, 0.086, 0.0125, 0.0, 0.0, 0.0])).is_ok());
        // positive diagonal, indefinite through the products
        let e = mass_props(&props(1.0, [1.0, 1.0, 1.0, 2.0, 0.0, 0.0])).unwrap_err();
        assert!(e.1.contains("positive semi-definite"), "{}", e.1);
        assert!(mass_props(&props(0.0, [s, s, s, 0.0, 0.0, 0.0])).is_ok());
        // a thin rod on its boundary (Izz = 0, Ixx = Iyy) is a body
        assert!(mass_props(&props(1.0, [s, s, 0.0, 0.0, 0.0, 0.0])).is_ok());
    }
}
