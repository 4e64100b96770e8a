// Benchmark model of the deposit (~210k triangles): a 42 mm sphere on a 3 mm plinth
// (the plinth's union with the sphere is left to the slicer). Sliced with PrusaSlicer by
// bench/deposit_bench.sh.
$fn = 460;
translate([0, 0, 21]) sphere(d = 42);
cylinder(d = 20, h = 3, $fn = 64);
