//! `crushsim`: the stand-in for LS-DYNA (see `lab::crushsim`). `crushsim i=main.k [ncpu=N] [memory=...]`.

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    std::process::exit(lab::crushsim::run::main(&args));
}
