//! The `frontseat` command line: parses arguments and hands over to the crates. Kept thin on purpose.
fn main() {
    println!("frontseat: under construction");
}
