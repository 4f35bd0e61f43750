//! Printing: the core's [`ModelProgram`] as Rust tokens.
//!
//! Everything lands inside `const _: () = { ... };`, reaches the runtime only through
//! `#krate::__private` (`::lincal_core` unless `#[calib(crate = "...")]` renames it), and uses
//! only `core` and `libm`, so it builds in a `#![no_std]` crate.
//!
//! This file depends on nothing else in the derive crate (only `lincal_core`, `syn`, `quote`,
//! `proc_macro2`), so tests can include it with `#[path]` and snapshot the exact code the
//! derive emits.

use lincal_core::model::geometry::ConstraintKind;
use lincal_core::program::{LinComb, ModelProgram, Op, Program, Summary};
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// What to print.
pub struct Input<'a> {
    /// The type the model is derived for.
    pub ident: &'a syn::Ident,
    /// Its generics.
    pub generics: &'a syn::Generics,
    /// Path of the runtime crate (`::lincal_core` by default).
    pub krate: &'a syn::Path,
    /// The programs and constants.
    pub program: &'a ModelProgram,
    /// Absolute path of the spec file, included so that editing it rebuilds.
    pub include: Option<&'a str>,
    /// A `measured_pose` spec's stated `position_std / orientation_std`: printed as
    /// `orientation_weight()` (`None`: the trait's default).
    pub orientation_weight: Option<f64>,
}

/// An `f64` expression for a number (negative numbers as `-lit`, non-finite ones by name).
fn num(x: f64) -> TokenStream {
    if x.is_nan() {
        quote!(::core::f64::NAN)
    } else if x.is_infinite() {
        if x > 0.0 {
            quote!(::core::f64::INFINITY)
        } else {
            quote!(::core::f64::NEG_INFINITY)
        }
    } else {
        let lit = Literal::f64_unsuffixed(x.abs());
        if x.is_sign_negative() && x != 0.0 {
            quote!(-#lit)
        } else {
            quote!(#lit)
        }
    }
}

fn usize_lit(x: usize) -> Literal {
    Literal::usize_unsuffixed(x)
}

fn value(v: usize) -> syn::Ident {
    format_ident!("v{}", v)
}

/// `c0 + c1*v1 - v2 ...` for an affine combination.
fn lin(l: &LinComb) -> TokenStream {
    let mut out = TokenStream::new();
    for (i, &(c, v)) in l.terms.iter().enumerate() {
        let x = value(v);
        let a = c.abs();
        let term = if a == 1.0 {
            quote!(#x)
        } else {
            let lit = num(a);
            quote!(#lit * #x)
        };
        match (i == 0, c < 0.0) {
            (true, true) => out.extend(quote!(-#term)),
            (true, false) => out.extend(term),
            (false, true) => out.extend(quote!(- #term)),
            (false, false) => out.extend(quote!(+ #term)),
        }
    }
    if l.terms.is_empty() {
        num(l.constant)
    } else {
        if l.constant != 0.0 {
            let lit = num(l.constant.abs());
            if l.constant < 0.0 {
                out.extend(quote!(- #lit));
            } else {
                out.extend(quote!(+ #lit));
            }
        }
        out
    }
}

/// The body of a function evaluating `prog`: its values as `let`s, then the output array.
fn body(prog: &Program, krate: &syn::Path) -> TokenStream {
    let libm = quote!(#krate::__private::libm);
    // `cos x` and `sin x` of the same `x` come from one `sincos(x)`, at the first of the two.
    let mut cos_of = vec![None; prog.ops.len()];
    let mut sin_of = vec![None; prog.ops.len()];
    for (i, op) in prog.ops.iter().enumerate() {
        match op {
            Op::Cos(x) => cos_of[*x] = Some(i),
            Op::Sin(x) => sin_of[*x] = Some(i),
            _ => {}
        }
    }
    let mut stmts = TokenStream::new();
    for (i, op) in prog.ops.iter().enumerate() {
        let v = value(i);
        if let Op::Cos(x) | Op::Sin(x) = op {
            if let (Some(c), Some(s)) = (cos_of[*x], sin_of[*x]) {
                if i == c.min(s) {
                    let (c, s, x) = (value(c), value(s), value(*x));
                    stmts.extend(quote!(let (#s, #c): (f64, f64) = #libm::sincos(#x);));
                }
                continue;
            }
        }
        let rhs = match op {
            Op::Q(k) => {
                let k = usize_lit(*k);
                quote!(q[#k])
            }
            Op::P(k) => {
                let k = usize_lit(*k);
                quote!(p[#k])
            }
            Op::Cos(x) => {
                let x = value(*x);
                quote!(#libm::cos(#x))
            }
            Op::Sin(x) => {
                let x = value(*x);
                quote!(#libm::sin(#x))
            }
            Op::Mul(a, b) => {
                let (a, b) = (value(*a), value(*b));
                quote!(#a * #b)
            }
            Op::Lin(l) => lin(l),
        };
        stmts.extend(quote!(let #v: f64 = #rhs;));
    }
    let n = prog.outputs.len();
    let zeros = prog.outputs.iter().filter(|o| o.is_zero()).count();
    if zeros * 4 >= n && n > 0 {
        let len = usize_lit(n);
        let mut sets = TokenStream::new();
        for (i, o) in prog.outputs.iter().enumerate() {
            if !o.is_zero() {
                let i = usize_lit(i);
                let e = lin(o);
                sets.extend(quote!(out[#i] = #e;));
            }
        }
        quote! {
            #stmts
            let mut out = [0.0f64; #len];
            #sets
            out
        }
    } else {
        let outs = prog.outputs.iter().map(lin);
        quote! {
            #stmts
            [#(#outs),*]
        }
    }
}

fn kind(k: ConstraintKind, krate: &syn::Path) -> TokenStream {
    let v = match k {
        ConstraintKind::Point => quote!(Point),
        ConstraintKind::Line2 => quote!(Line2),
        ConstraintKind::Line3 => quote!(Line3),
        ConstraintKind::Plane => quote!(Plane),
        ConstraintKind::PlaneNormal => quote!(PlaneNormal),
        ConstraintKind::Circle => quote!(Circle),
        ConstraintKind::Sphere => quote!(Sphere),
        ConstraintKind::Quadric => quote!(Quadric),
        ConstraintKind::Measured => quote!(Measured),
        ConstraintKind::MeasuredPose => quote!(MeasuredPose),
    };
    quote!(#krate::__private::ConstraintKind::#v)
}

fn doc(text: &str) -> TokenStream {
    let text = format!(" {text}");
    quote!(#[doc = #text])
}

/// The derive's whole output for `input`: the private tables, the inherent items and the
/// `CalibModel` impl, inside one `const _: () = { ... };`.
#[must_use]
pub fn expand(input: &Input<'_>) -> TokenStream {
    let s = &input.program.summary;
    let krate = input.krate;
    let pv = quote!(#krate::__private);
    let z = Sizes::of(s);
    let include = input.include.map(|path| {
        quote!(
            const _: &str = ::core::include_str!(#path);
        )
    });
    let tables = tables(input.program, krate, &pv, &z);
    let inherent = inherent_impl(input, &z);
    let model_impl = model_impl(input, &pv, &z);

    quote! {
        #[doc(hidden)]
        #[allow(
            non_upper_case_globals,
            unused_variables,
            unused_mut,
            clippy::all,
            clippy::pedantic,
            clippy::nursery
        )]
        const _: () = {
            #include

            #tables

            #inherent

            #model_impl
        };
    }
}

/// The sizes the generated code is typed by, as unsuffixed `usize` literals.
struct Sizes {
    /// Joints.
    n: Literal,
    /// Estimated parameters.
    np: Literal,
    /// Basis functions `K`.
    k: Literal,
    /// Equations `E`.
    e: Literal,
    /// Tip coordinates.
    dim: Literal,
    /// Constraints.
    nc: Literal,
    /// Constraint values, all constraints together.
    nv: Literal,
    /// Constraints plus one (the length of the offsets table).
    nc1: Literal,
    /// `E·K`, the generalized parameters.
    ek: Literal,
    /// `E·K·P`, the Jacobian.
    ekp: Literal,
    /// Monomials before reduction.
    naive: Literal,
    /// Identifiable combinations.
    ic: Literal,
    /// The kernel's scratch for `∂c/∂p` (`Tables::scratch_len`).
    scratch: Literal,
}

impl Sizes {
    fn of(s: &Summary) -> Self {
        let (n, np, k, e, nc) = (
            s.joints(),
            s.params(),
            s.basis_size(),
            s.equations(),
            s.constraint_kinds.len(),
        );
        Sizes {
            n: usize_lit(n),
            np: usize_lit(np),
            k: usize_lit(k),
            e: usize_lit(e),
            dim: usize_lit(s.dim),
            nc: usize_lit(nc),
            nv: usize_lit(s.constraint_offsets.last().copied().unwrap_or(0)),
            nc1: usize_lit(nc + 1),
            ek: usize_lit(e * k),
            ekp: usize_lit(e * k * np),
            naive: usize_lit(s.naive_size),
            ic: usize_lit(s.identifiable_count),
            scratch: usize_lit(lincal_core::model::factored::Tables::scratch_len(
                &s.chain.factors,
            )),
        }
    }
}

/// `Some(i)` or `None` as an `Option<usize>` expression.
fn option_usize(x: Option<usize>) -> TokenStream {
    match x {
        Some(i) => {
            let i = usize_lit(i);
            quote!(::core::option::Option::Some(#i))
        }
        None => quote!(::core::option::Option::None),
    }
}

/// The private tables the trait methods index (`__PRISMATIC`, `__LIMITS`, ..., `__CHAIN`):
/// constants rather than associated items, so the public surface stays the documented one.
fn tables(program: &ModelProgram, krate: &syn::Path, pv: &TokenStream, z: &Sizes) -> TokenStream {
    let s = &program.summary;
    let Sizes {
        n, np, e, nc, nc1, ..
    } = z;
    let factored = factored_tables(program, pv);
    let prismatic = &s.prismatic;
    let angle = &s.param_is_angle;
    let limits = s.limits.iter().map(|l| match l {
        Some([lo, hi]) => {
            let (lo, hi) = (num(*lo), num(*hi));
            quote!(::core::option::Option::Some([#lo, #hi]))
        }
        None => quote!(::core::option::Option::None),
    });
    let kinds = s.constraint_kinds.iter().map(|x| kind(*x, krate));
    let offsets = s.constraint_offsets.iter().map(|x| usize_lit(*x));
    let eq_con = s.equation_constraint.iter().map(|x| usize_lit(*x));
    let constant_index = option_usize(s.constant_index);
    let factors = chain_factors(s, pv);
    let nf = usize_lit(s.chain.factors.len());
    let value_params = s.chain.value_params.iter().map(|vs| {
        let vs = vs.iter().map(|v| option_usize(*v));
        quote!(&[#(#vs),*])
    });
    quote! {
        const __PRISMATIC: [bool; #n] = [#(#prismatic),*];
        const __LIMITS: [::core::option::Option<[f64; 2]>; #n] = [#(#limits),*];
        const __ANGLE: [bool; #np] = [#(#angle),*];
        const __KINDS: [#pv::ConstraintKind; #nc] = [#(#kinds),*];
        const __OFFSETS: [usize; #nc1] = [#(#offsets),*];
        const __EQUATION_CONSTRAINT: [usize; #e] = [#(#eq_con),*];
        const __CONSTANT_INDEX: ::core::option::Option<usize> = #constant_index;
        const __CHAIN: [#pv::Factor; #nf] = [#(#factors),*];
        const __VALUE_PARAMS: [&[::core::option::Option<usize>]; #nc] = [#(#value_params),*];
        #factored
    }
}

/// The kernel's tables (`__TABLES`, [`lincal_core::model::factored::Tables`]): the pivots
/// when `c(p)` is not straight-line code, `R`'s terms when `Φ̃(q)` is not; empty otherwise.
fn factored_tables(program: &ModelProgram, pv: &TokenStream) -> TokenStream {
    let c_kernel = program.generalized_params.is_none() || program.jacobian.is_none();
    // `from_model` builds the tables whenever a program needs them.
    let Some(t) = program
        .factored
        .as_ref()
        .filter(|_| program.basis.is_none() || c_kernel)
    else {
        return TokenStream::new();
    };
    let (dim, joints) = (usize_lit(t.dim), usize_lit(t.joints));
    let u8s = |v: &[u8]| {
        let v = v.iter().map(|x| Literal::u8_unsuffixed(*x));
        quote!(&[#(#v),*])
    };
    let u64s = |v: &[u64]| {
        let v = v.iter().map(|x| Literal::u64_unsuffixed(*x));
        quote!(&[#(#v),*])
    };
    let u32s = |v: &[u32]| {
        let v = v.iter().map(|x| Literal::u32_unsuffixed(*x));
        quote!(&[#(#v),*])
    };
    let empty = quote!(&[]);
    let (pivots, pivot_basis, value_params) = if c_kernel {
        let vp = t.value_params.iter().map(|v| option_usize(*v));
        (u64s(&t.pivots), u32s(&t.pivot_basis), quote!(&[#(#vp),*]))
    } else {
        (empty.clone(), empty.clone(), empty.clone())
    };
    let (monos, shared, term_basis, coefs, grid) = if program.basis.is_none() {
        let c = t.term_coefs.iter().map(|x| num(*x));
        (
            u64s(&t.term_monomials),
            u8s(&t.term_shared),
            u32s(&t.term_basis),
            quote!(&[#(#c),*]),
            u8s(&t.term_grid),
        )
    } else {
        (
            empty.clone(),
            empty.clone(),
            empty.clone(),
            empty.clone(),
            empty,
        )
    };
    quote! {
        static __TABLES: #pv::Tables<'static> = #pv::Tables {
            dim: #dim,
            joints: #joints,
            chain: &__CHAIN,
            kinds: &__KINDS,
            offsets: &__OFFSETS,
            equation_constraint: &__EQUATION_CONSTRAINT,
            value_params: #value_params,
            pivots: #pivots,
            pivot_basis: #pivot_basis,
            term_monomials: #monos,
            term_shared: #shared,
            term_basis: #term_basis,
            term_coefs: #coefs,
            term_grid: #grid,
        };
    }
}

/// The numeric chain as `Factor` literals, for the tip Jacobian at run time.
fn chain_factors(s: &Summary, pv: &TokenStream) -> Vec<TokenStream> {
    s.chain
        .factors
        .iter()
        .map(|f| {
            let rotation = f.rotation;
            let axis = match f.axis {
                lincal_core::model::chain::Axis::X => quote!(#pv::Axis::X),
                lincal_core::model::chain::Axis::Y => quote!(#pv::Axis::Y),
                lincal_core::model::chain::Axis::Z => quote!(#pv::Axis::Z),
            };
            let constant = num(f.constant);
            let joint = option_usize(f.joint);
            let terms = f.terms.iter().map(|t| match t {
                Some(t) => {
                    let (param, coef) = (usize_lit(t.param), num(t.coef));
                    quote!(::core::option::Option::Some(#pv::Term { param: #param, coef: #coef }))
                }
                None => quote!(::core::option::Option::None),
            });
            quote!(#pv::Factor { rotation: #rotation, axis: #axis, constant: #constant, joint: #joint, terms: [#(#terms),*] })
        })
        .collect()
}

/// The inherent `impl` of the model type: its associated constants and functions.
fn inherent_impl(input: &Input<'_>, z: &Sizes) -> TokenStream {
    let Input {
        ident, generics, ..
    } = input;
    let (impl_generics, ty_generics, where_clause) = generics.split_for_impl();
    let consts = associated_consts(&input.program.summary, z);
    let functions = functions(input.program, input.krate, z);
    quote! {
        #[allow(clippy::all, clippy::pedantic, clippy::nursery, unused_variables, unused_mut)]
        impl #impl_generics #ident #ty_generics #where_clause {
            #consts

            #functions
        }
    }
}

/// The documented associated constants (`NAME`, `DIM`, ..., `GAUGE`).
fn associated_consts(s: &Summary, z: &Sizes) -> TokenStream {
    let Sizes {
        n,
        np,
        k,
        e,
        dim,
        naive,
        ic,
        ..
    } = z;
    let name = &s.name;
    let param_names = &s.param_names;
    let basis_names = &s.basis_names;
    let nominals = s.param_nominals.iter().map(|x| num(*x));
    let identifiable = &s.identifiable;
    let held = &s.held;
    let gauge = s.gauge.iter().map(|g| {
        let entries = g.iter().map(|(n, c)| {
            let c = num(*c);
            quote!((#n, #c))
        });
        quote!(&[#(#entries),*])
    });
    let name_doc = doc(&format!("The spec's name, `{name}`."));
    let params_doc = doc(&format!(
        "Names of the {} estimated parameters, the order of `p`: `{}`.",
        s.params(),
        s.param_names.join("`, `")
    ));
    quote! {
        #name_doc
        pub const NAME: &'static str = #name;
        /// 2 (planar) or 3.
        pub const DIM: usize = #dim;
        /// Number of joints, the length of `q`.
        pub const JOINTS: usize = #n;
        /// Number of estimated parameters, the length of `p`.
        pub const PARAMS: usize = #np;
        /// `K`: the size of the column-reduced basis `Φ̃`.
        pub const BASIS_SIZE: usize = #k;
        /// Distinct joint monomials of the constraint function(s) before reduction.
        pub const NAIVE_SIZE: usize = #naive;
        /// `E`: number of scalar constraint equations.
        pub const EQUATIONS: usize = #e;
        /// Number of independent parameter combinations the constraint determines.
        pub const IDENTIFIABLE_COUNT: usize = #ic;
        #params_doc
        pub const PARAM_NAMES: [&'static str; #np] = [#(#param_names),*];
        /// Nominal value of each estimated parameter.
        pub const NOMINALS: [f64; #np] = [#(#nominals),*];
        /// Basis function names (`Φ̃_k` in terms of `c_i = cos q_i`, `s_i = sin q_i`).
        pub const BASIS_NAMES: [&'static str; #k] = [#(#basis_names),*];
        /// Per estimated parameter: identifiable on its own.
        pub const IDENTIFIABLE: [bool; #np] = [#(#identifiable),*];
        /// Per estimated parameter: held at its nominal value by the gauge rule.
        pub const HELD: [bool; #np] = [#(#held),*];
        /// The gauge directions (parameter changes the constraint cannot see), each a
        /// list of `(parameter, coefficient)`.
        pub const GAUGE: &'static [&'static [(&'static str, f64)]] = &[#(#gauge),*];
    }
}

/// The fixed-size functions (`basis`, `generalized_params`, `jacobian`, `tip`,
/// `constraint_values`, `equations`): the programs printed as straight-line code.
fn functions(program: &ModelProgram, krate: &syn::Path, z: &Sizes) -> TokenStream {
    let Sizes {
        n,
        np,
        k,
        e,
        dim,
        nv,
        ek,
        ekp,
        ..
    } = z;
    let scratch = &z.scratch;
    let basis = match &program.basis {
        Some(b) => body(b, krate),
        None => quote! {
            let mut out = [0.0f64; #k];
            __TABLES.basis(q, &mut out);
            out
        },
    };
    let cparams = match &program.generalized_params {
        Some(c) => body(c, krate),
        None => quote! {
            let vals = Self::constraint_values(p);
            let mut out = [0.0f64; #ek];
            __TABLES.generalized_params(p, &vals, &mut out);
            out
        },
    };
    let jac = match &program.jacobian {
        Some(j) => body(j, krate),
        None => quote! {
            let vals = Self::constraint_values(p);
            let mut scratch = [0.0f64; #scratch];
            let mut out = [0.0f64; #ekp];
            __TABLES.jacobian(p, &vals, &mut scratch, &mut out);
            out
        },
    };
    let tip = body(&program.tip, krate);
    let cvals = body(&program.constraint_values, krate);
    let s = &program.summary;
    let how = if program.basis.is_some() {
        "straight-line code: each sin/cos and each product computed once"
    } else {
        "the factored kernel: each monomial's prefix product computed once"
    };
    // The names in the doc while they fit on a line or two (all are in `BASIS_NAMES`).
    let names = if s.basis_size() <= 12 {
        format!(" `{}`", s.basis_names.join("`, `"))
    } else {
        String::new()
    };
    let basis_doc = doc(&format!(
        "`Φ̃(q)`: the {} basis functions{names} at the joint readings `q` ({how}).",
        s.basis_size(),
    ));
    quote! {
        #basis_doc
        #[must_use]
        pub fn basis(q: &[f64; #n]) -> [f64; #k] {
            #basis
        }

        /// `c(p)`: the generalized parameters, `E·K` values, equation-major
        /// (`out[e*K + k]`).
        #[must_use]
        pub fn generalized_params(p: &[f64; #np]) -> [f64; #ek] {
            #cparams
        }

        /// `∂c/∂p`: `E·K·P` values, `out[(e*K + k)*P + j] = ∂c_{e,k}/∂p_j`.
        #[must_use]
        pub fn jacobian(p: &[f64; #np]) -> [f64; #ekp] {
            #jac
        }

        /// The tip `x(q; p)` by forward kinematics (the numeric DH product).
        #[must_use]
        pub fn tip(q: &[f64; #n], p: &[f64; #np]) -> [f64; #dim] {
            #tip
        }

        /// Every constraint's values (canonical order), concatenated.
        #[must_use]
        pub fn constraint_values(p: &[f64; #np]) -> [f64; #nv] {
            #cvals
        }

        /// The constraint function(s) `h_e(q; p) = Σ_k c_{e,k}(p)·Φ̃_k(q)`, `E` values
        /// (zero when the tip is on the constraint; for a measured tip, the tip).
        #[must_use]
        pub fn equations(q: &[f64; #n], p: &[f64; #np]) -> [f64; #e] {
            let phi = Self::basis(q);
            let c = Self::generalized_params(p);
            let mut h = [0.0f64; #e];
            let mut e = 0;
            while e < #e {
                let mut k = 0;
                while k < #k {
                    h[e] += c[e * #k + k] * phi[k];
                    k += 1;
                }
                e += 1;
            }
            h
        }
    }
}

/// The `CalibModel` impl: every method forwards to an associated item or a private table.
fn model_impl(input: &Input<'_>, pv: &TokenStream, z: &Sizes) -> TokenStream {
    let Input {
        ident, generics, ..
    } = input;
    let (impl_generics, ty_generics, where_clause) = generics.split_for_impl();
    let describe = describe_methods(pv, z);
    let evaluate = evaluate_methods(input.program, pv, z);
    let relations = relations_method(&input.program.summary.relations, pv);
    let orientation_weight = input.orientation_weight.map(|w| {
        let w = num(w);
        quote! {
            fn orientation_weight(&self) -> f64 {
                #w
            }
        }
    });
    quote! {
        #[automatically_derived]
        #[allow(clippy::all, clippy::pedantic, clippy::nursery, unused_variables)]
        impl #impl_generics #pv::CalibModel for #ident #ty_generics #where_clause {
            #describe
            #evaluate
            #relations
            #orientation_weight
        }
    }
}

/// `relations()` returning the spec's relations as a constant (nothing without them: the
/// trait's default is the empty list).
fn relations_method(
    relations: &[lincal_core::model::geometry::Relation],
    pv: &TokenStream,
) -> TokenStream {
    use lincal_core::model::geometry::RelationKind;
    if relations.is_empty() {
        return TokenStream::new();
    }
    let n = Literal::usize_unsuffixed(relations.len());
    let items = relations.iter().map(|r| {
        let kind = match r.kind {
            RelationKind::Distance => quote!(Distance),
            RelationKind::SameNormal => quote!(SameNormal),
            RelationKind::Offset => quote!(Offset),
        };
        let [i, j] = r.between.map(Literal::usize_unsuffixed);
        let value = Literal::f64_suffixed(r.value);
        quote!(#pv::Relation { kind: #pv::RelationKind::#kind, between: [#i, #j], value: #value })
    });
    quote! {
        fn relations(&self) -> &[#pv::Relation] {
            const RELATIONS: [#pv::Relation; #n] = [#(#items),*];
            &RELATIONS
        }
    }
}

/// The `CalibModel` methods that describe the model: name, sizes, joints, parameters,
/// basis names and constraint kinds.
fn describe_methods(pv: &TokenStream, z: &Sizes) -> TokenStream {
    let Sizes {
        n,
        np,
        k,
        dim,
        nc,
        ic,
        ..
    } = z;
    quote! {
        fn name(&self) -> &str {
            Self::NAME
        }
        fn dim(&self) -> usize {
            #dim
        }
        fn joint_count(&self) -> usize {
            #n
        }
        fn joint_is_prismatic(&self, i: usize) -> bool {
            __PRISMATIC[i]
        }
        fn joint_limits(&self, i: usize) -> ::core::option::Option<[f64; 2]> {
            __LIMITS[i]
        }
        fn param_count(&self) -> usize {
            #np
        }
        fn param_name(&self, j: usize) -> &str {
            Self::PARAM_NAMES[j]
        }
        fn param_nominal(&self, j: usize) -> f64 {
            Self::NOMINALS[j]
        }
        fn param_is_angle(&self, j: usize) -> bool {
            __ANGLE[j]
        }
        fn param_identifiable(&self, j: usize) -> bool {
            Self::IDENTIFIABLE[j]
        }
        fn param_held(&self, j: usize) -> bool {
            Self::HELD[j]
        }
        fn identifiable_count(&self) -> usize {
            #ic
        }
        fn basis_size(&self) -> usize {
            #k
        }
        fn basis_name(&self, k: usize) -> &str {
            Self::BASIS_NAMES[k]
        }
        fn constant_index(&self) -> ::core::option::Option<usize> {
            __CONSTANT_INDEX
        }
        fn constraint_count(&self) -> usize {
            #nc
        }
        fn constraint_kind(&self, j: usize) -> #pv::ConstraintKind {
            __KINDS[j]
        }
    }
}

/// The `CalibModel` methods that evaluate the model (constraint values, basis, generalized
/// parameters, Jacobians, tip), each over the fixed-size associated function, and the chain.
fn evaluate_methods(program: &ModelProgram, pv: &TokenStream, z: &Sizes) -> TokenStream {
    let Sizes {
        np,
        k,
        e,
        dim,
        ek,
        ekp,
        scratch,
        ..
    } = z;
    // The kernel writes into the caller's buffer: no `E·K·P` array on the stack.
    let basis = if program.basis.is_some() {
        quote!(out[..#k].copy_from_slice(&Self::basis(#pv::head(q)));)
    } else {
        {
            let n = &z.n;
            quote!(__TABLES.basis(&q[..#n], out);)
        }
    };
    let cparams = if program.generalized_params.is_some() {
        quote!(out[..#ek].copy_from_slice(&Self::generalized_params(#pv::head(p)));)
    } else {
        quote! {
            let vals = Self::constraint_values(#pv::head(p));
            __TABLES.generalized_params(&p[..#np], &vals, out);
        }
    };
    let jac = if program.jacobian.is_some() {
        quote!(out[..#ekp].copy_from_slice(&Self::jacobian(#pv::head(p)));)
    } else {
        quote! {
            let vals = Self::constraint_values(#pv::head(p));
            let mut scratch = [0.0f64; #scratch];
            __TABLES.jacobian(&p[..#np], &vals, &mut scratch, out);
        }
    };
    quote! {
        fn constraint_values(&self, j: usize, p: &[f64], out: &mut [f64]) {
            let all = Self::constraint_values(#pv::head(p));
            let (lo, hi) = (__OFFSETS[j], __OFFSETS[j + 1]);
            out[..hi - lo].copy_from_slice(&all[lo..hi]);
        }
        fn equation_count(&self) -> usize {
            #e
        }
        fn equation_constraint(&self, e: usize) -> usize {
            __EQUATION_CONSTRAINT[e]
        }
        fn basis(&self, q: &[f64], out: &mut [f64]) {
            #basis
        }
        fn generalized_params(&self, p: &[f64], out: &mut [f64]) {
            #cparams
        }
        fn jacobian(&self, p: &[f64], out: &mut [f64]) {
            #jac
        }
        fn tip(&self, q: &[f64], p: &[f64], out: &mut [f64]) {
            out[..#dim].copy_from_slice(&Self::tip(#pv::head(q), #pv::head(p)));
        }
        fn tip_jacobian(&self, q: &[f64], p: &[f64], tip: &mut [f64], jac: &mut [f64]) {
            let mut twists = [[0.0f64; 6]; #np];
            #pv::tip_jacobian(&__CHAIN, #dim, q, p, tip, jac, &mut twists);
        }
        fn constraint_value_param(&self, j: usize, v: usize) -> ::core::option::Option<usize> {
            __VALUE_PARAMS[j][v]
        }
        fn chain(&self) -> &[#pv::Factor] {
            &__CHAIN
        }
    }
}
