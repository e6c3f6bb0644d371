//! The blocks dexcut's grbl model plans for a program, as the input of the real grbl
//! planner's harness (`scripts/grbl_reference`, README.md there).
//!
//! `cargo run --release -p schedule --example grbl_blocks -- PROGRAM.ngc SETTINGS.txt > blocks.txt`
//! (SETTINGS.txt: a `$$` dump; its `$12` cuts the arcs.)

#[path = "../tests/grbl_io/mod.rs"]
mod grbl_io;

fn main() {
    let file = std::env::args()
        .nth(1)
        .expect("usage: grbl_blocks PROGRAM.ngc");
    let path = grbl_io::program(std::path::Path::new(&file));
    print!("{}", grbl_io::blocks_text(&path, &grbl_io::settings()));
}
