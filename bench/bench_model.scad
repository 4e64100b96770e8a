// The benchmark part of the deposit, deviation and verify figures (issues 4 and 5): a
// twisted, lobed 40 mm column of 200,996 triangles. PrusaSlicer (Ender-3 profile, 0.2 mm
// layers) makes ~156k lines of G-code and ~4.7 m of filament from it, the size the issues
// name ("~200k triangles, ~160k lines, ~4.5 m"). One linear_extrude, no CSG: OpenSCAD
// writes it in seconds. Built by bench/make_bench_data.sh.
n = 500;
function r(a) = 15.6 + 2.2 * sin(7 * a) + 0.6 * sin(31 * a);
pts = [for (i = [0 : n - 1]) let(a = 360 * i / n) [r(a) * cos(a), r(a) * sin(a)]];
linear_extrude(height = 40, twist = 60, slices = 200) polygon(pts);
