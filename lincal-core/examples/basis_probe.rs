use lincal_core::model::CalibModel;
fn main() {
    let path = std::env::args().nth(1).expect("spec path");
    let t = std::time::Instant::now();
    let spec = match lincal_core::spec::from_yaml_file(std::path::Path::new(&path)) {
        Ok(s) => s,
        Err(e) => { eprintln!("{e}"); std::process::exit(2) }
    };
    let m = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
    println!("time {:?}", t.elapsed());
    println!("naive {} K {} ident {}", m.naive_size(), m.basis_size(), m.identifiability().count);
    if m.basis_size() < 40 { for b in m.basis_names() { println!("  {b}"); } 
    for (e, row) in m.generalized_param_strings().iter().enumerate() { for (k, c) in row.iter().enumerate() { println!("c[{e}][{k}] = {c}"); } } }
    println!("{:?}", m.identifiable_split());
    println!("held {:?}", m.identifiability().held);
    println!("gauge {:?}", m.gauge());
}
