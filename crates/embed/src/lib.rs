//! `embed_built!("VAR")`: the bytes of a file that cargo builds before the crate using it, if
//! the file is there.
//!
//! `VAR` names a compile-time environment variable (set by the using crate's build script with
//! `cargo:rustc-env=VAR=PATH`) that holds an absolute path. The macro expands to
//! `Some(include_bytes!("PATH") as &[u8])` when the file exists — so rustc records it and the crate
//! is rebuilt when it changes — and to `None` when it does not (under `cargo check` and
//! `cargo clippy`, which build no libraries) or when `VAR` is unset.
//!
//! savme's binary embeds the bundled simulator's FMU library (a `cdylib` of a dependency,
//! written by the same rustc run as the `rlib` the binary links, so always there when the
//! binary is built): `savme fmu pack` then works from a lone copy of the binary.
//!
//! ```ignore
//! const LIBRARY: Option<&[u8]> = savme_embed::embed_built!("SAVME_SIM_FMU_EMBED");
//! ```
use proc_macro::{Literal, TokenStream, TokenTree};

/// `Some(include_bytes!(path))` for the path in the compile-time environment variable named by
/// the string literal argument, if that file exists; else `None`. See the crate docs.
#[proc_macro]
pub fn embed_built(input: TokenStream) -> TokenStream {
    let var = match variable_name(input) {
        Ok(v) => v,
        Err(message) => return compile_error(&message),
    };
    let path = std::env::var(&var)
        .ok()
        .filter(|p| std::path::Path::new(p).is_file());
    let code = match path {
        Some(p) => format!(
            "::core::option::Option::Some(::core::include_bytes!({}) as &[u8])",
            Literal::string(&p)
        ),
        None => "::core::option::Option::None::<&[u8]>".to_string(),
    };
    code.parse()
        .unwrap_or_else(|_| compile_error("embed_built!: bad path"))
}

/// The one string literal argument, unquoted.
fn variable_name(input: TokenStream) -> Result<String, String> {
    let tokens: Vec<TokenTree> = input.into_iter().collect();
    let [TokenTree::Literal(lit)] = tokens.as_slice() else {
        return Err(
            "embed_built! takes one string literal: the environment variable's name".into(),
        );
    };
    let text = lit.to_string();
    text.strip_prefix('"')
        .and_then(|t| t.strip_suffix('"'))
        .filter(|t| !t.is_empty() && !t.contains(['\\', '"']))
        .map(str::to_string)
        .ok_or_else(|| format!("embed_built!: {text} is not a plain string literal"))
}

fn compile_error(message: &str) -> TokenStream {
    format!("::core::compile_error!({})", Literal::string(message))
        .parse()
        .unwrap_or_default()
}
