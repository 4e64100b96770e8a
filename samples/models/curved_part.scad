// printtwin sample: sloped and curved surfaces for settings comparisons: a cylinder
// (r 12 mm, 10 mm tall) with a cone (to r 6 mm, 8 mm tall) and a dome (r 5 mm) on top.
$fn = 48;
union() {
  cylinder(r = 12, h = 10);
  translate([0, 0, 10 - 0.01]) cylinder(r1 = 12, r2 = 6, h = 8);
  translate([0, 0, 18 - 0.02]) intersection() {
    sphere(r = 5);
    translate([-7, -7, 0]) cube([14, 14, 7]);
  }
}
