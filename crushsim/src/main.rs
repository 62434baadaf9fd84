//! `crushsim`: the stand-in for LS-DYNA (see the crate's README). `crushsim i=main.k [ncpu=N] [memory=...]`.

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    std::process::exit(crushsim::run::main(&args));
}
