//! Every load-time validation rule gives an error naming the file, the line and the node.

mod common;

use firefleet_bt::{BuildError, xml};

fn errors(text: &str) -> String {
    let doc = match xml::parse_str(text, "bad.xml") {
        Ok(d) => d,
        Err(e) => return e.to_string(),
    };
    xml::validate(&doc, &common::registry())
        .expect_err("must be rejected")
        .to_string()
}

fn wrap(body: &str) -> String {
    format!("<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"T\">\n{body}\n</BehaviorTree>\n</root>")
}

#[test]
fn unknown_node() {
    let e = errors(&wrap("<Sequence>\n<Fly name=\"up\"/>\n</Sequence>"));
    assert_eq!(e, "bad.xml:4: Fly \"up\": unknown node type 'Fly'");
}

#[test]
fn wrong_child_count() {
    assert_eq!(
        errors(&wrap("<Inverter/>")),
        "bad.xml:3: Inverter: Inverter takes exactly 1 child, found 0"
    );
    let e = errors(&wrap("<AlwaysSuccess><AlwaysFailure/></AlwaysSuccess>"));
    assert!(
        e.contains("AlwaysSuccess takes no children, found 1"),
        "{e}"
    );
    let e = errors(&wrap("<IfThenElse><AlwaysSuccess/></IfThenElse>"));
    assert!(e.contains("2 to 3 children"), "{e}");
    let e = errors(&wrap("<Sequence/>"));
    assert!(e.contains("at least 1 child"), "{e}");
}

#[test]
fn undeclared_port() {
    let e = errors(&wrap(
        "<Repeat num_cycles=\"2\" speed=\"3\"><AlwaysSuccess/></Repeat>",
    ));
    assert_eq!(
        e,
        "bad.xml:3: Repeat: 'speed' is not a port of Repeat (ports: num_cycles)"
    );
}

#[test]
fn missing_required_port() {
    let e = errors(&wrap("<Timeout><AlwaysSuccess/></Timeout>"));
    assert_eq!(e, "bad.xml:3: Timeout: missing required port 'msec'");
}

#[test]
fn mistyped_literal_and_mistyped_entry() {
    let e = errors(&wrap(
        "<Repeat num_cycles=\"twice\"><AlwaysSuccess/></Repeat>",
    ));
    assert_eq!(
        e,
        "bad.xml:3: Repeat: port 'num_cycles': 'twice' is not an int"
    );
    let e = errors(&wrap(
        "<Sequence><Flag value=\"{x}\"/><Repeat num_cycles=\"{x}\"><AlwaysSuccess/></Repeat></Sequence>",
    ));
    assert!(
        e.contains("Repeat: port 'num_cycles': entry 'x' is used as bool and as int"),
        "{e}"
    );
}

#[test]
fn impossible_parallel_threshold() {
    let e = errors(&wrap(
        "<Parallel success_count=\"3\"><AlwaysSuccess/><AlwaysSuccess/></Parallel>",
    ));
    assert!(
        e.contains("success_count=3 cannot be met with 2 children"),
        "{e}"
    );
}

#[test]
fn a_caller_can_branch_on_the_cause() {
    let doc = xml::parse_str(&wrap("<Sequence>\n<Fly/>\n</Sequence>"), "bad.xml").unwrap();
    let xml::XmlErrors(es) = xml::validate(&doc, &common::registry()).unwrap_err();
    assert_eq!(es.len(), 1);
    assert_eq!(es[0].line, 4);
    assert_eq!(
        es[0].problem,
        xml::Problem::Build(BuildError::UnknownType("Fly".into()))
    );
    let doc = xml::parse_str(
        &wrap("<Repeat num_cycles=\"-2\"><AlwaysSuccess/></Repeat>"),
        "bad.xml",
    )
    .unwrap();
    let xml::XmlErrors(es) = xml::validate(&doc, &common::registry()).unwrap_err();
    assert!(
        matches!(
            es[0].problem,
            xml::Problem::Build(BuildError::OutOfRange {
                port: "num_cycles",
                value: -2,
                ..
            })
        ),
        "{:?}",
        es[0]
    );
}

#[test]
fn unknown_and_recursive_subtrees() {
    let e = errors(&wrap("<SubTree ID=\"Nope\"/>"));
    assert_eq!(e, "bad.xml:3: SubTree: no BehaviorTree with ID 'Nope'");
    let text = "<root BTCPP_format=\"4\" main_tree_to_execute=\"A\">\n<BehaviorTree ID=\"A\"><SubTree ID=\"B\"/></BehaviorTree>\n<BehaviorTree ID=\"B\">\n<SubTree ID=\"A\"/>\n</BehaviorTree>\n</root>";
    let e = errors(text);
    assert!(
        e.contains("bad.xml:4: SubTree: recursive subtree: A -> B -> A"),
        "{e}"
    );
}

#[test]
fn several_errors_are_all_reported() {
    let e = errors(&wrap(
        "<Sequence>\n<Fly/>\n<Inverter/>\n<Timeout><AlwaysSuccess/></Timeout>\n</Sequence>",
    ));
    assert_eq!(e.lines().count(), 3, "{e}");
    assert!(
        e.contains("bad.xml:4: Fly")
            && e.contains("bad.xml:5: Inverter")
            && e.contains("bad.xml:6: Timeout"),
        "{e}"
    );
}

#[test]
fn file_level_problems() {
    assert!(
        errors("<root><BehaviorTree ID=\"T\"><AlwaysSuccess/></BehaviorTree></root>")
            .contains("missing BTCPP_format")
    );
    assert!(errors("<root BTCPP_format=\"3\"/>").contains("only format 4"));
    assert!(
        errors("<root BTCPP_format=\"4\"><BehaviorTree ID=\"T\"><A></BehaviorTree></root>")
            .starts_with("bad.xml:1: not well-formed")
    );
    let two = "<root BTCPP_format=\"4\"><BehaviorTree ID=\"A\"><AlwaysSuccess/></BehaviorTree><BehaviorTree ID=\"B\"><AlwaysSuccess/></BehaviorTree></root>";
    assert!(errors(two).contains("no main_tree_to_execute"));
    let e = errors(
        "<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"A\"><AlwaysSuccess/><AlwaysSuccess/></BehaviorTree></root>",
    );
    assert_eq!(
        e,
        "bad.xml:2: BehaviorTree \"A\": must have exactly one root node, found 2"
    );
}

#[test]
fn includes_are_relative_to_the_including_file_and_errors_name_the_included_file() {
    let dir = std::env::temp_dir().join(format!("bt-include-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(
        dir.join("main.xml"),
        "<root BTCPP_format=\"4\" main_tree_to_execute=\"Main\">\n<include path=\"sub/lib.xml\"/>\n<BehaviorTree ID=\"Main\"><SubTree ID=\"Lib\"/></BehaviorTree>\n</root>",
    )
    .unwrap();
    std::fs::write(dir.join("sub/lib.xml"), "<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"Lib\">\n<Inverter><AlwaysFailure/></Inverter>\n</BehaviorTree>\n</root>").unwrap();
    let doc = xml::load_file(&dir.join("main.xml")).unwrap();
    let mut t = xml::build(&doc, &common::registry()).unwrap();
    assert_eq!(
        t.tick(0.0, &mut common::Ctx::default()),
        firefleet_bt::Status::Success
    );

    std::fs::write(dir.join("sub/lib.xml"), "<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"Lib\">\n<Inverter/>\n</BehaviorTree>\n</root>").unwrap();
    let doc = xml::load_file(&dir.join("main.xml")).unwrap();
    let e = xml::validate(&doc, &common::registry())
        .unwrap_err()
        .to_string();
    assert!(e.contains("sub/lib.xml:3: Inverter"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
