use std::time::Instant;
use trimorph::exact::*;
use rand::{Rng, SeedableRng};
fn main() {
    let n = 90; let m = 60;
    let mut rng = rand::rngs::SmallRng::seed_from_u64(3);
    let rows = (0..m).map(|i| {
        let base = i * (n - 4) / m;
        let mut cols: Vec<usize> = Vec::new();
        while cols.len() < 4 { let c = base + rng.gen_range(0..6).min(n - 1 - base); if !cols.contains(&c) { cols.push(c); } }
        let a: i64 = rng.gen_range(1..=16); let b: i64 = rng.gen_range(1..=16); let c: i64 = rng.gen_range(1..=16);
        vec![(cols[0], Int::from(a)), (cols[1], Int::from(b)), (cols[2], Int::from(c)), (cols[3], Int::from(-(a + b + c)))]
    }).collect();
    let r = SparseIntMatrix::from_rows(n, rows).unwrap();
    let derived: Vec<usize> = (15..76).filter(|&s| s != 45).collect();
    let mut cm = vec![None; n]; for (k,&s) in derived.iter().enumerate() { cm[s]=Some(k); }
    let rows_e: Vec<usize> = (0..m).collect();
    let red = r.select(&rows_e, &cm, derived.len());
    for meth in [Simplification::Turner, Simplification::Gcd] {
        let t = Instant::now();
        let f = Ldu::factor(&red, LduOptions::with(meth));
        let t1 = t.elapsed();
        let rh = red.select(f.independent_rows(), &(0..derived.len()).map(Some).collect::<Vec<_>>(), derived.len());
        let t = Instant::now();
        let lsq = WeightedLsq::new(rh.clone(), &vec![rat_int(1); derived.len()], meth).unwrap();
        let t2 = t.elapsed();
        let b: Vec<Vec<Rat>> = (0..rh.rows()).map(|i| vec![rat_int(i as i64 % 3)]).collect();
        let h: Vec<Vec<Rat>> = (0..derived.len()).map(|i| vec![rat_int(i as i64 % 5)]).collect();
        let t = Instant::now();
        let x = lsq.solve(&b, &h);
        let t3 = t.elapsed();
        let maxbits = x.iter().flatten().map(|v| v.denom().bits().max(v.numer().bits())).max().unwrap();
        println!("{meth}: factor {:?} (rank {}, maxbits {}, nnz {}), lsq-new {:?}, solve {:?}, sol bits {}", t1, f.rank(), f.max_bits(), f.nnz(), t2, t3, maxbits);
    }
}
