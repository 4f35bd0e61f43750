//! The derive input as this crate sees it: the type (name, generics) and its `#[calib]`
//! attributes.

use syn::{DeriveInput, Generics, Ident};

use crate::attr::{self, Attrs};
use crate::ctxt::Ctxt;

/// The type the model is derived for.
pub struct Container {
    /// The type's name.
    pub ident: Ident,
    /// Its generics (the impls carry them over).
    pub generics: Generics,
    /// The `#[calib(...)]` attributes.
    pub attrs: Attrs,
}

impl Container {
    /// Reads the derive input; problems go to `cx`.
    pub fn from_ast(input: &DeriveInput, cx: &Ctxt) -> Container {
        let attrs = attr::read(&input.attrs, cx);
        if attrs.first.is_none() {
            cx.error_spanned_by(
                &input.ident,
                "#[derive(CalibModel)] needs a `#[calib(...)]` attribute: \
                 `#[calib(spec = \"specs/robot.yaml\")]` or an inline spec \
                 (`#[calib(dim = 2, joint(revolute, a = a1, home = th1), ...)]`)",
            );
        }
        Container {
            ident: input.ident.clone(),
            generics: input.generics.clone(),
            attrs,
        }
    }
}
