// printtwin sample: a 40 x 12 x 4 mm plate with vertical through-holes of diameter
// 0.3, 0.6, 1, 2 and 3 mm. The 0.3 mm hole is narrower than one 0.45 mm line width and
// closes when printed: `printtwin check` must report narrow_gap there.
plate = [40, 12, 4];
diameters = [0.3, 0.6, 1, 2, 3];
xs = [4, 10, 17, 25, 34];

difference() {
  cube(plate);
  for (i = [0 : len(diameters) - 1])
    translate([xs[i], plate[1] / 2, -1])
      cylinder(d = diameters[i], h = plate[2] + 2, $fn = 24);
}
