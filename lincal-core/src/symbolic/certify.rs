//! The derive's certificate: the factored tables ([`crate::model::factored`]) give the model's
//! own constraint functions, exactly.
//!
//! For every equation `e`, `h_e(q; p) = Σ_k c_{e,k}(p)·Φ̃_k(q)` is an identity of polynomials in
//! the joint functions and the spec's symbols (lengths, and each angle's `(cos, sin)` pair
//! modulo `cos² + sin² = 1`). Both sides are evaluated in the integers modulo the prime
//! `P = 2⁶¹ − 1`, at random points of that variety (each pair a rational point of the unit
//! circle, `((1 − t²)/(1 + t²), 2t/(1 + t²))`):
//! - `h_e` from the expansion's slot polynomials along the chain, as the identifiability
//!   analysis evaluates it (`identify::sampled::equation_values`);
//! - `Φ̃_k` from the exact reduction's `R` (rational coefficients);
//! - `c_{e,k}` by the kernel's own contraction over the tables (`Tables::contract`, the code
//!   the derived model runs, in the field), each factor's step from the slots its amount reads
//!   (`spec::chain::SlotKey`).
//!
//! For the derive, `∂c/∂p` too: `Σ_k ∂c_{e,k}/∂p_j·Φ̃_k(q) = ∂h_e/∂p_j(q; p)` for every
//! parameter, the kernel's product rule (`Tables::jacobian_with`) against the chain's own
//! forward-mode derivatives. The factors' steps come from the slots, so each factor's parameter
//! terms (which parameter, which sign) are proven through `∂c/∂p`; its constant (a known angle
//! or length, in `f64`) is left to the derive's numerical comparison.
//!
//! The tables' terms are checked to be `R`'s, term by term (their coefficients rounded to
//! `f64`, exact when dyadic). Since the `Φ̃_k` are linearly independent, the identities make
//! the kernel's `c` and `∂c/∂p` the exact ones.
//!
//! **Failure bound.** Let `D_e = h_e − Σ_k c_{e,k} Φ̃_k` for tables that are wrong. Every
//! motion's slot and every joint's functions enter `D_e` with degree at most two (a product of
//! one entry per motion, twice for a circle, sphere or quadric; a joint's codes are of degree
//! two at most), and the constraint's values add two. Substituting each pair's
//! parametrisation and clearing the denominators `(1 + t²)^d` doubles a pair's degree, so a
//! non-zero polynomial of degree at most `4(m + n) + 2 ≤ 2·deg` remains, `deg` =
//! [`degree_bound`] for `m` motions and `n` joints. By the Schwartz–Zippel lemma it vanishes at
//! one random point with probability at most `2·deg/P` (unless `P` divides every one of its
//! coefficients, which are products of the spec's own numbers). The certificate evaluates at
//! [`POINTS`] independent points, each a fresh parameter point and joint reading: wrong tables
//! pass with probability
//! at most `(2·deg/P)^POINTS`, below `10⁻³⁰` for any chain the kernel holds. The points come
//! from a fixed seed, so that a build is reproducible; the bound is over that draw, which
//! nothing in the tables can see (as for the identifiability analysis).

use super::basis_part::BasisPart;
use super::eval::generic_point_mod;
use super::factored::FactoredTables;
use super::identify::sampled::{equation_gradients, equation_values, readings_mod};
use super::modp::{self, Mp, Scalar};
use super::poly::Poly;
use super::slots::{slot_polys, SlotPolys};
use crate::error::{Error, Result};
use crate::model::chain::Axis;
use crate::model::factored::{unpack, Step};
use crate::model::CalibModel as _;
use crate::spec::chain::{Chain, SlotKey};
use crate::spec::Spec;
use crate::symbolic::SymbolicModel;

/// Independent random points the identity is checked at.
pub const POINTS: usize = 2;

/// A model's certificate once asked for ([`SymbolicModel::factored_certificate`]).
pub(super) type Memo = Option<std::result::Result<Certificate, String>>;

/// What the certificate proved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Certificate {
    /// Points checked.
    pub points: usize,
    /// Equations checked at each.
    pub equations: usize,
    /// The bound on the total degree of each equation's difference.
    pub degree: usize,
    /// The probability that wrong tables pass, at most: `(2·degree/P)^points`.
    pub failure_bound: f64,
    /// Whether `∂c/∂p` was proven too (`Σ_k ∂c_{e,k}/∂p_j·Φ̃_k = ∂h_e/∂p_j`, the kernel's own
    /// product rule run in the field, every equation and parameter, with the same bound).
    pub jacobian: bool,
}

/// The most values of `c(p)` (`E·K`) whose factored tables the reports certify
/// ([`SymbolicModel::factored_certificate`]), and of `∂c/∂p` (`E·K·P`) they certify too: 40
/// times the 7-joint arm's `c` on a point with every parameter unknown, the 9-joint arm's on a
/// measured pose (236 196), at most about 0.1 s each.
pub const CERTIFY_MAX_VALUES: usize = 1 << 18;

impl SymbolicModel {
    /// Proves that the factored tables `t` (from [`SymbolicModel::factored`]) give this
    /// model's constraint functions, `h_e(q; p) = Σ_k c_{e,k}(p)·Φ̃_k(q)`, exactly modulo a
    /// prime at random points, with the kernel's own contraction (the module docs state the
    /// failure bound); with `jacobian`, `∂c/∂p` too, the kernel's product rule against the
    /// chain's forward-mode derivatives.
    ///
    /// # Errors
    /// The basis could not be built, or the tables disagree with the model (an engine bug).
    pub fn certify_factored(&self, t: &FactoredTables, jacobian: bool) -> Result<Certificate> {
        certify(self.spec(), self.part()?, t, jacobian)
    }

    /// Where the reports leave `c(p)` in factored form (not printed: beyond the terms printed,
    /// or never expanded), the certificate of the tables that `#[derive(CalibModel)]` and the
    /// run-time model evaluate it with ([`SymbolicModel::certify_factored`]), `∂c/∂p`
    /// included where it has at most [`CERTIFY_MAX_VALUES`] values; `None` where `c(p)` is
    /// printed, has more than [`CERTIFY_MAX_VALUES`] values, or the chain is one the kernel
    /// does not hold.
    pub fn factored_certificate(&self) -> Option<Result<Certificate>> {
        let once = self.certificate.get_or_init(|| {
            let values = self.basis_size().saturating_mul(self.equation_count());
            if self.c_printed() || values > CERTIFY_MAX_VALUES {
                return None;
            }
            let t = self.factored().ok()?;
            // `∂c/∂p` too (and with it the tables' parameter terms) where it is as small.
            let jacobian = values.saturating_mul(self.param_count()) <= CERTIFY_MAX_VALUES;
            Some(
                self.certify_factored(&t, jacobian)
                    .map_err(|e| e.to_string()),
            )
        });
        once.clone().map(|r| r.map_err(Error::other))
    }
}

/// Half a bound on the degree of `h_e − Σ c_{e,k}Φ̃_k` once each pair is parametrised and the
/// denominators cleared (`4(m + n) + 2` at most, module docs), for `m` motions and `n` joints.
#[must_use]
pub fn degree_bound(factors: usize, joints: usize) -> usize {
    2 * (factors + 2 * joints + 1) + 2
}

/// Proves that the tables `t`, built from the reduction `part` of `spec`, give `spec`'s
/// constraint functions (module docs).
///
/// # Errors
/// The tables disagree with the model (an engine bug), or a factor reads slots the
/// certificate cannot map (the same).
pub(super) fn certify(
    spec: &Spec,
    part: &BasisPart,
    t: &FactoredTables,
    jacobian: bool,
) -> Result<Certificate> {
    let bug = |what: String| {
        Error::other(format!(
            "the factored model disagrees with the exact one ({what}): an engine bug, please \
             report it with the spec"
        ))
    };
    let sp = slot_polys(spec)?;
    let (_, keys) = Chain::keyed(spec);
    if keys.len() != t.chain.len() {
        return Err(bug(format!(
            "{} factors in the tables, {} in the spec's chain",
            t.chain.len(),
            keys.len()
        )));
    }
    let vars = &part.expansion.vars;
    let jv = vars.joint_vars;
    if sp.vars.joint_vars != jv || sp.vars.vars[..jv] != vars.vars[..jv] {
        return Err(bug("the joint variables differ".into()));
    }
    terms_are_r(part, t).map_err(bug)?;
    let (k, ne) = (t.pivot_basis.len(), t.equation_constraint.len());
    let tables = t.tables();
    let mut rng = modp::Rng::new(0x5eed_cafe_f00d_d00d);
    for point in 0..POINTS {
        let vals = generic_point_mod(&sp.vars, rng.next_u64());
        let vals: Vec<Mp> = vals.into_iter().map(Mp).collect();
        let reading = readings_mod(&sp.vars, 1, &mut rng);
        let h = equation_values(&sp, &vals, &reading);
        if h.len() != ne {
            return Err(bug(format!(
                "{} equations in the tables, {} in the chain",
                ne,
                h.len()
            )));
        }
        let steps = steps_at(&sp, &keys, t, &vals).map_err(bug)?;
        let values = constraint_values(&sp, t, &vals).map_err(bug)?;
        let mut c = vec![Mp(0); ne * k];
        tables.contract(&steps, &values, &mut c);
        let phi = basis_at(part, &reading[0]).map_err(bug)?;
        for (e, he) in h.iter().enumerate() {
            let sum = (0..k).fold(Mp(0), |acc, b| acc + c[e * k + b] * phi[b]);
            if sum != he[0] {
                return Err(bug(format!("equation {e} at random point {point}")));
            }
        }
        if jacobian {
            jacobian_holds(&sp, t, (&steps, &values, &vals), &reading[0], &phi)
                .map_err(|what| bug(format!("{what} at random point {point}")))?;
        }
    }
    let degree = degree_bound(t.chain.len(), t.joints);
    Ok(Certificate {
        points: POINTS,
        equations: ne,
        degree,
        failure_bound: (2.0 * degree as f64 / modp::P as f64).powi(POINTS as i32),
        jacobian,
    })
}

/// `Σ_k ∂c_{e,k}/∂p_j·Φ̃_k(q) = ∂h_e/∂p_j(q)` at one point: the kernel's `∂c/∂p` from the
/// factors' `steps`, the constraint `values` and every variable's value `vals`, against the
/// chain's own forward-mode derivatives, at the reading `joint` where `Φ̃` is `phi`.
fn jacobian_holds(
    sp: &SlotPolys,
    t: &FactoredTables,
    (steps, values, vals): (&[Step<Mp>], &[Mp], &[Mp]),
    joint: &[Mp],
    phi: &[Mp],
) -> std::result::Result<(), String> {
    let (k, ne, np) = (phi.len(), t.equation_constraint.len(), sp.param_names.len());
    let terms = t
        .chain
        .iter()
        .flat_map(|f| f.terms.iter().flatten().map(|t| t.param));
    if terms
        .chain(t.value_params.iter().flatten().copied())
        .any(|j| j >= np)
    {
        return Err(format!("a parameter beyond the {np} estimated"));
    }
    let grads = equation_gradients(sp, vals, np, joint);
    let len = crate::model::factored::Tables::scratch_len(&t.chain);
    let mut scratch = vec![Mp(0); len];
    let mut jac = vec![Mp(0); ne * k * np];
    t.tables()
        .jacobian_with(steps, np, values, &mut scratch, &mut jac);
    for (e, g) in grads.iter().enumerate() {
        for (j, &want) in g.iter().enumerate() {
            let sum = (0..k).fold(Mp(0), |acc, b| acc + jac[(e * k + b) * np + j] * phi[b]);
            if sum != want {
                return Err(format!("∂/∂{} of equation {e}", sp.param_names[j]));
            }
        }
    }
    Ok(())
}

/// The tables' terms are `R`'s nonzeros: the same monomials per basis function, the
/// coefficients rounded to `f64`.
fn terms_are_r(part: &BasisPart, t: &FactoredTables) -> std::result::Result<(), String> {
    let (n, k) = (t.joints, part.reduction.basis.len());
    // The pivots: one per basis function, each function once.
    let mut seen = vec![false; k];
    let permutation = t.pivot_basis.iter().all(|&b| {
        let b = b as usize;
        b < k && !std::mem::replace(&mut seen[b], true)
    });
    if t.pivots.len() != k || t.pivot_basis.len() != k || !permutation {
        return Err("the pivots are not one per basis function".into());
    }
    let mut want: Vec<(Vec<u8>, u32, f64)> = Vec::new();
    for (b, terms) in part.reduction.basis.iter().enumerate() {
        for (m, c) in terms {
            let codes =
                super::factored::codes_of(m, &part.expansion.vars, n).map_err(|e| e.to_string())?;
            want.push((codes, b as u32, c.to_f64()));
        }
    }
    want.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(&b.1)));
    let have = t
        .term_monomials
        .iter()
        .zip(&t.term_basis)
        .zip(&t.term_coefs)
        .map(|((&m, &b), &c)| (unpack(m, n)[..n].to_vec(), b, c));
    if want.len() != t.term_basis.len() || !want.iter().cloned().eq(have) {
        return Err("the basis's terms are not R's".into());
    }
    // What `Tables::basis` reads besides: the shared prefixes and the full grid.
    let shared = (0..want.len()).map(|i| match i.checked_sub(1) {
        Some(prev) => want[i]
            .0
            .iter()
            .zip(&want[prev].0)
            .take_while(|(a, b)| a == b)
            .count() as u8,
        None => 0,
    });
    if !shared.eq(t.term_shared.iter().copied())
        || super::factored::full_grid(&want, k, n) != t.term_grid
    {
        return Err("the basis's shared prefixes or grid are not R's".into());
    }
    Ok(())
}

/// A slot polynomial modulo the prime at `vals` (`None`: a coefficient whose denominator
/// the prime divides).
fn eval(p: &Poly, vals: &[Mp]) -> Option<Mp> {
    p.terms
        .iter()
        .try_fold(Mp(0), |acc, (m, c)| Some(acc + term(m, c, vals)?))
}

/// `c·m` modulo the prime at the variables' values `vals`.
fn term(m: &super::monomial::Mono, c: &super::coef::Coef, vals: &[Mp]) -> Option<Mp> {
    let coef = Mp::coef(c)?;
    Some(
        m.factors()
            .fold(coef, |t, (v, e)| (0..e).fold(t, |t, _| t * vals[v])),
    )
}

/// [`eval`], or why not.
fn value(p: &Poly, vals: &[Mp]) -> std::result::Result<Mp, String> {
    eval(p, vals).ok_or_else(|| "a coefficient with no value modulo the prime".to_string())
}

/// Each factor's parameter-only step at `vals`, from the slots its amount reads: a rotation
/// by `sign·angle` has cosine `cos angle` and sine `sign·sin angle`, a translation the signed
/// sum of its lengths.
fn steps_at(
    sp: &SlotPolys,
    keys: &[Vec<(SlotKey, f64)>],
    t: &FactoredTables,
    vals: &[Mp],
) -> std::result::Result<Vec<Step<Mp>>, String> {
    let signed = |x: Mp, sign: f64| if sign < 0.0 { -x } else { x };
    let mut steps = Vec::with_capacity(keys.len());
    for (f, slots) in t.chain.iter().zip(keys) {
        // The kernel reads a term's sign into `∂c/∂p` and its value into the amount: only
        // ±1 is both (`Term`), which `∂c/∂p`'s proof then pins to the right parameter.
        if let Some(term) = f.terms.iter().flatten().find(|t| t.coef.abs() != 1.0) {
            return Err(format!("a parameter term of coefficient {}", term.coef));
        }
        let a = match f.axis {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        };
        if f.rotation {
            let [(key, sign)] = slots[..] else {
                return Err(format!("a rotation of {} slots", slots.len()));
            };
            let (c, s) = pair(sp, key).ok_or_else(|| format!("{key:?} is not an angle"))?;
            steps.push(Step::Rot(
                a,
                signed(value(&s, vals)?, sign),
                value(&c, vals)?,
            ));
        } else {
            let mut sum = Mp(0);
            for &(key, sign) in slots {
                let l = length(sp, key).ok_or_else(|| format!("{key:?} is not a length"))?;
                sum = sum + signed(value(l, vals)?, sign);
            }
            steps.push(Step::Trans(a, sum));
        }
    }
    Ok(steps)
}

/// The `(cos, sin)` pair of an angle slot.
fn pair(sp: &SlotPolys, key: SlotKey) -> Option<(Poly, Poly)> {
    let frame_angle = |b: &super::slots::BaseSlots, k: usize| b.rpy.get(k.checked_sub(3)?).cloned();
    match key {
        SlotKey::Base(k) => frame_angle(sp.base.as_ref()?, k),
        SlotKey::Origin(i, k) => frame_angle(sp.links.get(i)?.origin.as_ref()?, k),
        SlotKey::Home(i) | SlotKey::Theta(i) => Some(sp.links.get(i)?.angle.clone()),
        SlotKey::Alpha(i) => Some(sp.links.get(i)?.alpha.clone()),
        // No tilt in the slots: the constant 0.
        SlotKey::Beta(i) => Some(
            sp.links
                .get(i)?
                .beta
                .clone()
                .unwrap_or((Poly::int(1), Poly::zero())),
        ),
        // A tool frame's rotation that no measured pose reads: after the tool's translation,
        // it turns nothing the constraints see, so any angle, 0, stands for it.
        SlotKey::ToolRotation(k) => match &sp.tool_rpy {
            Some(rpy) => rpy.get(k).cloned(),
            None => Some((Poly::int(1), Poly::zero())),
        },
        _ => None,
    }
}

/// The polynomial of a length slot.
fn length(sp: &SlotPolys, key: SlotKey) -> Option<&Poly> {
    match key {
        SlotKey::Base(k) => sp.base.as_ref()?.t.get(k),
        SlotKey::Origin(i, k) => sp.links.get(i)?.origin.as_ref()?.t.get(k),
        SlotKey::D(i) => Some(&sp.links.get(i)?.d),
        SlotKey::A(i) => Some(&sp.links.get(i)?.a),
        SlotKey::Offset(i) => sp.links.get(i)?.offset.as_ref(),
        SlotKey::Tool(k) => sp.tool.get(k),
        _ => None,
    }
}

/// Every constraint's values at `vals`, concatenated as the tables read them.
fn constraint_values(
    sp: &SlotPolys,
    t: &FactoredTables,
    vals: &[Mp],
) -> std::result::Result<Vec<Mp>, String> {
    let out: Vec<Mp> = sp
        .constraints
        .iter()
        .flat_map(|(_, v)| v.iter().map(|p| value(p, vals)))
        .collect::<std::result::Result<_, _>>()?;
    if Some(&out.len()) != t.offsets.last() {
        return Err("the constraints' values differ in number".into());
    }
    Ok(out)
}

/// `Φ̃(q)` modulo the prime from the exact `R`, at one reading (the joint variables' values).
fn basis_at(part: &BasisPart, joint: &[Mp]) -> std::result::Result<Vec<Mp>, String> {
    part.reduction
        .basis
        .iter()
        .map(|terms| {
            terms
                .iter()
                .try_fold(Mp(0), |acc, (m, c)| Some(acc + term(m, c, joint)?))
                .ok_or_else(|| "a coefficient of R with no value modulo the prime".to_string())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use crate::model::chain::Axis;
    use crate::model::CalibModel as _;
    use crate::symbolic::testutil::{every_repo_spec_path, repo_spec};
    use crate::symbolic::SymbolicModel;

    /// Every spec of the repository is certified (`c(p)` and `∂c/∂p`), and the certificate
    /// refuses tables that are wrong in each of their parts: two basis functions' pivots
    /// swapped, a pivot read at another's monomial, the first joint turning about another
    /// axis, a term of `R` moved to another basis function, a factor's parameter term read as
    /// another parameter or negated.
    #[test]
    fn the_certificate_proves_every_spec_and_refuses_wrong_tables() {
        let paths = every_repo_spec_path();
        let mut refused = [0usize; 6];
        let mut tried = [0usize; 6];
        for name in &paths {
            let m = SymbolicModel::from_spec(&repo_spec(name)).unwrap();
            let t = m.factored().unwrap_or_else(|e| panic!("{name}: {e}"));
            let c = m
                .certify_factored(&t, true)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(c.failure_bound < 1e-30, "{name}: {c:?}");
            let mut wrong = Vec::new();
            if t.pivots.len() > 2 {
                let mut w = t.clone();
                w.pivot_basis.swap(1, 2);
                wrong.push((0, w));
                let mut w = t.clone();
                w.pivots[0] = w.pivots[1];
                wrong.push((1, w));
            }
            if let Some(f) = t.chain.iter().position(|f| f.joint == Some(0)) {
                let mut w = t.clone();
                w.chain[f].axis = match w.chain[f].axis {
                    Axis::Z => Axis::X,
                    _ => Axis::Z,
                };
                wrong.push((2, w));
            }
            if t.term_basis.len() > 1 && t.pivots.len() > 1 {
                let mut w = t.clone();
                w.term_basis[0] = (w.term_basis[0] + 1) % t.pivots.len() as u32;
                wrong.push((3, w));
            }
            // A parameter term of the chain read as another parameter, or negated: the
            // amounts come from the slots in the field, so only `∂c/∂p` sees these.
            let termed = t.chain.iter().position(|f| f.terms[0].is_some());
            if let (Some(f), true) = (termed, m.param_count() > 1) {
                let mut w = t.clone();
                if let Some(term) = w.chain[f].terms[0].as_mut() {
                    term.param = (term.param + 1) % m.param_count();
                }
                wrong.push((4, w));
                let mut w = t.clone();
                if let Some(term) = w.chain[f].terms[0].as_mut() {
                    term.coef = -term.coef;
                }
                wrong.push((5, w));
            }
            for (i, w) in wrong {
                tried[i] += 1;
                if m.certify_factored(&w, true).is_err() {
                    refused[i] += 1;
                } else {
                    eprintln!("{name}: sabotage {i} passes");
                }
            }
        }
        assert_eq!(refused, tried, "sabotages refused of tried");
        assert!(tried.iter().all(|&n| n >= 30), "{tried:?}");
    }

    /// A tool frame of constant rotation that no measured pose reads (a sphere, an unknown
    /// point, a plane; validation refuses an unknown one): its rotation turns nothing the
    /// constraint sees, and the certificate proves the tables as for a tool point (it took
    /// the rotation for an engine bug before).
    #[test]
    fn a_tool_frame_that_no_pose_reads_is_certified() {
        for (rotation, constraint, params) in [
            (
                "roll: 0.3, pitch: -0.2, yaw: 1.1",
                "sphere: {center: [cx, cy, cz], radius: r}",
                "cx: {nominal: 0.5}\n  cy: {nominal: 0}\n  cz: {nominal: 0.2}\n  r: {nominal: 0.1}",
            ),
            (
                "roll: 0, pitch: 0.5, yaw: -0.7",
                "point: {p: [cx, cy, cz]}",
                "cx: {nominal: 0.5}\n  cy: {nominal: 0}\n  cz: {nominal: 0.2}",
            ),
            (
                "roll: 0.3, pitch: -0.2, yaw: 1.1",
                "plane: {normal: [0, 0, 1], offset: cz}",
                "cz: {nominal: 0.2}",
            ),
        ] {
            let text = format!(
                "name: frame\ndim: 3\njoints:\n  \
                 - {{type: revolute, a: a1, alpha: pi/2, d: 0.3, home: th1}}\n  \
                 - {{type: revolute, a: a2, alpha: 0.4, home: th2}}\n\
                 tool: {{x: tx, y: 0.01, z: 0.1, {rotation}}}\n\
                 params:\n  a1: {{nominal: 0.05}}\n  a2: {{nominal: 0.4}}\n  \
                 th1: {{nominal: 0}}\n  th2: {{nominal: 0}}\n  tx: {{nominal: 0.02}}\n  \
                 {params}\nconstraint:\n  {constraint}\n"
            );
            let spec = crate::spec::from_yaml_str(&text, None)
                .unwrap_or_else(|e| panic!("{constraint}: {e}\n{text}"));
            let m = SymbolicModel::from_spec(&spec).unwrap();
            let t = m.factored().unwrap();
            m.certify_factored(&t, true)
                .unwrap_or_else(|e| panic!("{constraint}: {e}"));
        }
    }
}
