use super::*;

#[test]
fn a_unit_patrols_to_the_far_end_from_where_it_starts_in_its_lane() {
    let t = Tunnel::straight(300.0, 10.0, 6.3, 2);
    let (right, left) = (t.lane_center_y(0), t.lane_center_y(1));
    assert_eq!(
        patrol_goal(&t, Point2::new(5.0, right)),
        t.point_at(Chainage::new(290.0), right)
    );
    assert_eq!(
        patrol_goal(&t, Point2::new(295.0, left + 0.4)),
        t.point_at(Chainage::new(10.0), left),
        "in from the east portal, it patrols west"
    );
}
