// printtwin sample: four bridges spanning 5 / 10 / 20 / 40 mm between pairs of pillars, on a
// 56 x 50 x 1 mm base plate. Each pillar is 4 mm wide (X), 8 mm deep (Y) and 6 mm tall
// above the plate; each deck is 1.2 mm thick and as deep as its pillars. Printed without
// support, every deck's first layer is a bridge over its span.
plate = [56, 50, 1];
spans = [5, 10, 20, 40];
pillar = [4, 8, 6];
deck = 1.2;

union() {
  cube(plate);
  for (i = [0 : len(spans) - 1]) {
    y = 2 + 12 * i;
    translate([2, y, plate[2] - 0.01]) cube([pillar[0], pillar[1], pillar[2] + 0.01]);
    translate([2 + pillar[0] + spans[i], y, plate[2] - 0.01]) cube([pillar[0], pillar[1], pillar[2] + 0.01]);
    translate([2, y, plate[2] + pillar[2]]) cube([2 * pillar[0] + spans[i], pillar[1], deck]);
  }
}
