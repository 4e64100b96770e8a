// printtwin sample: four walls 0.2 / 0.4 / 0.8 / 1.2 mm thick, 30 mm long and 10 mm tall,
// standing on a 30 x 24 x 1 mm base plate (walls run along X, spaced 5 mm in Y).
// `printtwin check` must report thin_wall (minimum 0.2 mm, below the 0.4 mm nozzle).
// Slicers drop the 0.2 mm wall (and often the 0.4 mm one): used by the deviation tests.
plate = [30, 24, 1];
wall_height = 10;
thicknesses = [0.2, 0.4, 0.8, 1.2];

union() {
  cube(plate);
  for (i = [0 : len(thicknesses) - 1])
    translate([0, 4 + 5 * i, plate[2] - 0.01])  // small overlap so the union is one shell
      cube([plate[0], thicknesses[i], wall_height + 0.01]);
}
