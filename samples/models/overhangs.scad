// printtwin sample: four ledges whose outer face leans 30 / 45 / 60 / 75 degrees from
// vertical, on a 44 x 44 x 2 mm base plate. Each ledge is 8 mm tall and 8 mm deep (Y);
// its foot is 5 mm wide (X) and the leaning face starts at the plate's top.
// `printtwin check` (default limit 45 deg) must report overhang for the 60 and 75 deg faces.
plate = [44, 44, 2];
height = 8;
depth = 8;
foot = 5;
angles = [30, 45, 60, 75];

module ledge(angle) {
  // XZ profile extruded along +Y.
  rotate([90, 0, 0]) translate([0, 0, -depth])
    linear_extrude(height = depth)
      polygon([[0, 0], [foot, 0], [foot + height * tan(angle), height], [0, height]]);
}

union() {
  cube(plate);
  for (i = [0 : len(angles) - 1])
    translate([2, 2 + 11 * i, plate[2] - 0.01]) ledge(angles[i]);
}
