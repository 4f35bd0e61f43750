//! What the derive emits when the spec is wrong: the errors as `compile_error!`s, and beside
//! them a stub `CalibModel` impl whose methods only panic, so that code using the type as a
//! model does not add a cascade of "trait not implemented" errors (thiserror's approach).

use proc_macro2::TokenStream;
use quote::quote;

/// The errors plus the stub impl for `ident`.
pub fn expand(
    ident: &syn::Ident,
    generics: &syn::Generics,
    krate: &syn::Path,
    errors: &syn::Error,
) -> TokenStream {
    let errors = errors.to_compile_error();
    let (impl_generics, ty_generics, where_clause) = generics.split_for_impl();
    let pv = quote!(#krate::__private);
    let stub = quote!(::core::panic!(
        "lincal: #[derive(CalibModel)] failed; see the compile errors"
    ));
    quote! {
        #errors
        #[allow(unused_variables, clippy::all)]
        const _: () = {
            impl #impl_generics #pv::CalibModel for #ident #ty_generics #where_clause {
                fn name(&self) -> &str { #stub }
                fn dim(&self) -> usize { #stub }
                fn joint_count(&self) -> usize { #stub }
                fn joint_is_prismatic(&self, i: usize) -> bool { #stub }
                fn joint_limits(&self, i: usize) -> ::core::option::Option<[f64; 2]> { #stub }
                fn param_count(&self) -> usize { #stub }
                fn param_name(&self, j: usize) -> &str { #stub }
                fn param_nominal(&self, j: usize) -> f64 { #stub }
                fn param_is_angle(&self, j: usize) -> bool { #stub }
                fn param_identifiable(&self, j: usize) -> bool { #stub }
                fn param_held(&self, j: usize) -> bool { #stub }
                fn identifiable_count(&self) -> usize { #stub }
                fn basis_size(&self) -> usize { #stub }
                fn basis_name(&self, k: usize) -> &str { #stub }
                fn constant_index(&self) -> ::core::option::Option<usize> { #stub }
                fn constraint_count(&self) -> usize { #stub }
                fn constraint_kind(&self, j: usize) -> #pv::ConstraintKind { #stub }
                fn constraint_values(&self, j: usize, p: &[f64], out: &mut [f64]) { #stub }
                fn equation_count(&self) -> usize { #stub }
                fn equation_constraint(&self, e: usize) -> usize { #stub }
                fn basis(&self, q: &[f64], out: &mut [f64]) { #stub }
                fn generalized_params(&self, p: &[f64], out: &mut [f64]) { #stub }
                fn jacobian(&self, p: &[f64], out: &mut [f64]) { #stub }
                fn tip(&self, q: &[f64], p: &[f64], out: &mut [f64]) { #stub }
                fn tip_jacobian(&self, q: &[f64], p: &[f64], tip: &mut [f64], jac: &mut [f64]) { #stub }
                fn constraint_value_param(&self, j: usize, v: usize) -> ::core::option::Option<usize> { #stub }
                fn chain(&self) -> &[#pv::Factor] { #stub }
            }
        };
    }
}
