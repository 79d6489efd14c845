//! Computes the GGX albedo tables of `src/bsdf/albedo_table.rs` and prints that file:
//! `cargo run --release --example albedo_table > src/bsdf/albedo_table.rs`.

use lucent::bsdf::albedo::{N, NR, compute_row};

fn main() {
    let rows: Vec<_> = (0..NR).map(compute_row).collect();
    println!("//! Directional albedo of the GGX lobe (see `albedo.rs`): A for F = 1, B for F = (1 - v.h)^5,");
    println!("//! one row per roughness node, one column per sqrt(cos theta_o) node. Written by");
    println!("//! `cargo run --release --example albedo_table`; do not edit.");
    println!();
    for (name, pick) in [("A", 0), ("B", 1)] {
        println!("/// The {name} albedos.");
        println!("#[rustfmt::skip]");
        println!("pub(super) static {name}: [[f32; {N}]; {NR}] = [");
        for row in &rows {
            let values = if pick == 0 { &row.0 } else { &row.1 };
            let text: Vec<String> = values.iter().map(|v| format!("{v:?}")).collect();
            println!("    [{}],", text.join(", "));
        }
        println!("];");
    }
}
