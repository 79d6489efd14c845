//! Computes the sheen albedo table of `src/bsdf/sheen_table.rs` and prints that file:
//! `cargo run --release --example sheen_table > src/bsdf/sheen_table.rs`.

use lucent::bsdf::sheen::{N, compute_table};

fn main() {
    println!("//! Directional albedo of the white Charlie sheen lobe (see `sheen.rs`), one row per");
    println!("//! sqrt(alpha) node, one column per cos theta_o node. Written by");
    println!("//! `cargo run --release --example sheen_table`; do not edit.");
    println!();
    println!("/// The albedos.");
    println!("#[rustfmt::skip]");
    println!("pub(super) static TABLE: [[f32; {N}]; {N}] = [");
    for row in compute_table() {
        let text: Vec<String> = row.iter().map(|v| format!("{v:?}")).collect();
        println!("    [{}],", text.join(", "));
    }
    println!("];");
}
